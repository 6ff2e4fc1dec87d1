"""Uniform, textureless, identical and swapped pairs: an honest result with a warning (a swapped pair:
an error), never a crash."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from robustness._inputs import error_line


@pytest.mark.parametrize("image, reason", [("uniform.png", "no edges to start from (textureless)"),
                                           ("smooth.png", "no seed reached the similarity threshold")])
def test_textureless_pair_gives_density_0_and_says_why(inputs, run_cli, tmp_path, image, reason):
    right = shutil.copy(inputs / image, tmp_path / "right.png")      # two cameras facing a blank wall
    code, out, _, log = run_cli("disparity", inputs / image, right, "-o", tmp_path / "d.npy", "--json")
    assert code == 0
    assert json.loads(out)["density"] == 0.0
    assert np.isnan(np.load(tmp_path / "d.npy")).all()
    assert "no match:" in log and reason in log


@pytest.mark.parametrize("command", [["detect", "--focal", "138", "--baseline", "0.12"], ["disparity"]])
def test_one_file_given_twice_is_refused(inputs, run_cli, tmp_path, command):
    out = ["--out", tmp_path / "o"] if command[0] == "detect" else ["-o", tmp_path / "d.npy"]
    code, _, err, _ = run_cli(command[0], inputs / "uniform.png", f"{inputs}/./uniform.png", *out, *command[1:])
    assert code == 1 and "are one and the same; a stereo pair needs the two cameras' images" in err
    assert not (tmp_path / "o").exists() and not (tmp_path / "d.npy").exists()


def test_textureless_pair_detects_nothing_with_a_warning(inputs, run_cli, tmp_path):
    right = shutil.copy(inputs / "uniform.png", tmp_path / "right.png")
    code, out, _, log = run_cli("detect", inputs / "uniform.png", right, "--out", tmp_path / "o",
                                "--focal", "138", "--baseline", "0.12")
    assert code == 0 and "No obstacles found." in out
    assert "no match:" in log
    assert json.loads((tmp_path / "o" / "obstacles.json").read_text())["obstacles"] == []


def test_identical_images_are_flagged_as_all_disparity_zero(inputs, run_cli, tmp_path):
    copy = shutil.copy(inputs / "left.png", tmp_path / "copy.png")    # one file twice is refused (below)
    code, out, _, log = run_cli("disparity", inputs / "left.png", copy, "-o", tmp_path / "d.npy")
    assert code == 0
    d = np.load(tmp_path / "d.npy")
    assert np.nanmax(np.abs(d)) < 0.5
    assert "are the left and right images the same?" in log


@pytest.mark.parametrize("calibrated", [True, False])
def test_identical_images_report_no_obstacle(inputs, run_cli, tmp_path, calibrated):
    calibration = ["--calib", inputs / "scene" / "calibration.json"] if calibrated else []
    copy = shutil.copy(inputs / "left.png", tmp_path / "copy.png")
    code, out, _, log = run_cli("detect", inputs / "left.png", copy, "--out", tmp_path / "o", *calibration)
    assert code == 0 and "No obstacles found." in out
    assert "are the left and right images the same?" in log
    if not calibrated:   # the whole image at disparity 0 was once reported as obstacle #1, confidence 1.00
        assert "at infinity: median disparity 0.00 px" in out


def test_swapped_images_are_refused_and_nothing_is_written(inputs, run_cli, tmp_path):
    # every disparity of a swapped pair is negative: its "obstacles" would be noise in a confident table
    code, out, err, log = run_cli("detect", inputs / "right.png", inputs / "left.png", "--out", tmp_path / "o",
                                  "--calib", inputs / "scene" / "calibration.json")
    assert code == 1 and "look swapped" not in log             # the error alone says it (it was said twice)
    assert "look swapped" in error_line(err) and "give the left camera's image first" in error_line(err)
    assert out == "" and list(tmp_path.iterdir()) == []


def test_the_right_order_is_not_flagged_as_swapped(inputs, run_cli, tmp_path):
    code, _, _, log = run_cli("detect", inputs / "left.png", inputs / "right.png", "--out", tmp_path / "o",
                              "--calib", inputs / "scene" / "calibration.json")
    assert code == 0 and "swapped" not in log and "no match" not in log
    check = json.loads((tmp_path / "o" / "obstacles.json").read_text())["run"]["inputs"]["rectification_check"]
    assert check["rectified"] is True and check["swapped"] is False


def test_an_unrectified_pair_is_said_in_the_report_too(run_cli, tmp_path):
    # a reader of obstacles.json could not tell: the warning went to the terminal only
    from stereo_obstacles.fileio import write_image
    from stereo_obstacles.synthetic import RenderOptions, RightCameraError, default_scene, render_pair

    pair = render_pair(default_scene(320, 240), RenderOptions(right_error=RightCameraError(rotation_deg=(0.5, 0.3, 0.4))))
    write_image(tmp_path / "left.png", pair.left)
    write_image(tmp_path / "right.png", pair.right)
    code, _, _, log = run_cli("detect", tmp_path / "left.png", tmp_path / "right.png", "--out", tmp_path / "o")
    assert code == 0 and "does not look rectified" in log
    check = json.loads((tmp_path / "o" / "obstacles.json").read_text())["run"]["inputs"]["rectification_check"]
    assert check["rectified"] is False and check["vertical_offset"]["median_px"] > 1.0
