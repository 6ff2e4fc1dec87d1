"""Inputs the fuzz run found that escaped as exceptions other than StereoObstaclesError."""

from __future__ import annotations

import io

import numpy as np
import pytest

from stereo_obstacles.calibration_files import read_calibration
from stereo_obstacles.camera_calibration import read_camera_calibration
from stereo_obstacles.errors import CalibrationError, InputFileError
from stereo_obstacles.fileio import read_disparity, read_npy, read_pfm


def _npy_bytes() -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, np.zeros((2, 3), np.float32))
    return buffer.getvalue()


def test_a_npy_whose_header_is_cut_inside_the_dict_is_an_input_error(tmp_path):
    data = bytearray(_npy_bytes())
    header_end = data.index(b"}")
    data[header_end] = ord(" ")  # the header's Python literal no longer closes: TokenError in NumPy
    path = tmp_path / "broken.npy"
    path.write_bytes(bytes(data))
    with pytest.raises(InputFileError, match="is not a valid .npy file"):
        read_npy(path)
    with pytest.raises(InputFileError):
        read_disparity(path)


@pytest.mark.parametrize("scale", [b"-1-0", b"-"])
def test_a_pfm_scale_that_is_not_a_number_is_an_input_error(tmp_path, scale):
    path = tmp_path / "bad.pfm"
    path.write_bytes(b"Pf\n2 2\n" + scale + b"\n" + b"\0" * 16)
    with pytest.raises(InputFileError, match="bad PFM scale"):
        read_pfm(path)


@pytest.mark.parametrize("content", [
    "%YAML:1.0\n---\n- 1\n- 2\n",  # a list at the top, where OpenCV expects a map
    "%YAML:1.0\n---\nP1: !!opencv-matrix\n   rows: 3\n   cols: 4\n   dt: d\n   data: [ 1., 2. ]\n"
    "P2: !!opencv-matrix\n   rows: 3\n   cols: 4\n   dt: d\n   data: [ 1., 2. ]\n",  # too few numbers
])
def test_malformed_opencv_yaml_is_a_calibration_error(tmp_path, content):
    path = tmp_path / "calib.yaml"
    path.write_text(content)
    with pytest.raises(CalibrationError, match=str(path)):
        read_calibration(path)
    with pytest.raises(CalibrationError, match=str(path)):
        read_camera_calibration(path)
