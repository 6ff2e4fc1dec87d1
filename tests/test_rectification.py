"""Calibrated rectification: the camera-pair calibration, its files, and exact rectification of a
mis-mounted synthetic right camera and of a Middlebury pair turned by a known amount."""

from __future__ import annotations

import json

import numpy as np
import pytest

from _rectification_cases import perturbed_middlebury, synthetic_case, truth_kwargs
from stereo_obstacles.camera_calibration import (CameraPairCalibration, read_camera_calibration,
                                                 read_camera_pair_json, write_camera_pair_json, write_opencv_yaml)
from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.disparity_metrics import evaluate_disparity
from stereo_obstacles.errors import CalibrationError, ImageMismatchError, InvalidInputError, OutputError
from stereo_obstacles.matching import match
from stereo_obstacles.rectification import rectify_calibration
from stereo_obstacles.rectification_check import check_rectification
from stereo_obstacles.rectification_evaluation import rectified_ground_truth
from stereo_obstacles.rectification_quality import vertical_offset_stats

K = [[500.0, 0.0, 159.5], [0.0, 500.0, 119.5], [0.0, 0.0, 1.0]]
IDEAL = CameraPairCalibration(K, None, K, None, np.eye(3), [-0.1, 0.0, 0.0], 320, 240)


@pytest.fixture(scope="module")
def synthetic():
    pair, calibration = synthetic_case()
    rectification = rectify_calibration(calibration)
    return pair, calibration, rectification


def test_camera_pair_validation():
    with pytest.raises(CalibrationError, match="not a rotation matrix"):
        CameraPairCalibration(K, None, K, None, np.ones((3, 3)), [-0.1, 0, 0], 320, 240)
    with pytest.raises(CalibrationError, match="millimetres given as metres"):
        CameraPairCalibration(K, None, K, None, np.eye(3), [-120.0, 0, 0], 320, 240)
    with pytest.raises(CalibrationError, match="coefficients"):
        CameraPairCalibration(K, [0.1, 0.2, 0.3], K, None, np.eye(3), [-0.1, 0, 0], 320, 240)
    with pytest.raises(CalibrationError, match="camera_matrix_left"):
        CameraPairCalibration(np.zeros((3, 3)), None, K, None, np.eye(3), [-0.1, 0, 0], 320, 240)
    with pytest.raises(CalibrationError, match="320x240 images, the images are 640x480"):
        IDEAL.check_image_size(640, 480)
    assert IDEAL.baseline_m == pytest.approx(0.1)
    assert IDEAL.distortion_left.shape == (5,)


def test_json_and_yaml_round_trips(tmp_path):
    calibration = CameraPairCalibration(K, [-0.2, 0.05, 0.001, -0.002, 0.01], K, None,
                                        rotation_matrix_z(0.5), [-0.12, 0.001, 0.002], 320, 240, rms_px=0.3)
    write_camera_pair_json(tmp_path / "pair.json", calibration)
    assert json.loads((tmp_path / "pair.json").read_text())["format"] == "stereo-obstacles/camera-pair-calibration"
    for loaded in (read_camera_pair_json(tmp_path / "pair.json"), read_camera_calibration(tmp_path / "pair.json")):
        assert np.allclose(loaded.rotation, calibration.rotation)
        assert np.allclose(loaded.distortion_left, calibration.distortion_left)
        assert loaded.rms_px == 0.3
    # read as a rectified rig it was "not a stereo-obstacles/calibration document", with no hint (review)
    from stereo_obstacles.calibration_files import read_calibration
    with pytest.raises(CalibrationError, match="raw cameras' calibration that calibrate writes, not a rectified rig: "
                                               "read it with camera_calibration.read_camera_calibration"):
        read_calibration(tmp_path / "pair.json")
    write_opencv_yaml(tmp_path / "pair.yml", calibration, rectify_calibration(calibration).opencv_matrices())
    loaded = read_camera_calibration(tmp_path / "pair.yml")
    assert isinstance(loaded, CameraPairCalibration)
    assert np.allclose(loaded.translation_m, calibration.translation_m)
    assert np.allclose(loaded.camera_matrix_right, calibration.camera_matrix_right)
    assert loaded.image_size == (320, 240)
    with pytest.raises(OutputError, match="must end in .yml"):
        write_opencv_yaml(tmp_path / "pair.txt", calibration)
    with pytest.raises(InvalidInputError, match="rectified: expected a dict of named matrices"):
        write_opencv_yaml(tmp_path / "pair.yml", calibration, rectified=rectify_calibration(calibration))


def rotation_matrix_z(degrees: float) -> np.ndarray:
    a = np.radians(degrees)
    return np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])


def test_rectified_calibrations_still_read_as_before(tmp_path):
    path = tmp_path / "calib.txt"
    path.write_text("cam0=[500 0 160; 0 500 120; 0 0 1]\ncam1=[500 0 160; 0 500 120; 0 0 1]\n"
                    "doffs=0\nbaseline=100\nwidth=320\nheight=240\n")
    assert isinstance(read_camera_calibration(path), StereoCalibration)


def test_shared_opencv_file_is_an_unrectified_pair_needing_its_unit(shared_dataset):
    path = shared_dataset("calibration_examples") / "opencv_stereo_chessboard" / \
        "cameraParams_from_CppStereoMatching.yml"
    with pytest.raises(CalibrationError, match="--calib-unit mm"):
        read_camera_calibration(path)
    loaded = read_camera_calibration(path, length_unit="mm")
    assert isinstance(loaded, CameraPairCalibration)
    assert loaded.baseline_m == pytest.approx(0.0836, abs=5e-4)
    assert loaded.distortion_left.shape == (14,)


def test_refuses_vertical_and_swapped_rigs():
    with pytest.raises(CalibrationError, match="not side by side"):
        rectify_calibration(CameraPairCalibration(K, None, K, None, np.eye(3), [0, -0.1, 0], 320, 240))
    with pytest.raises(CalibrationError, match="swapped"):
        rectify_calibration(CameraPairCalibration(K, None, K, None, np.eye(3), [0.1, 0, 0], 320, 240))


def test_ideal_rig_rectifies_to_itself():
    rectification = rectify_calibration(IDEAL)
    assert rectification.rectified.focal_px == pytest.approx(500.0, rel=1e-6)
    assert rectification.rectified.baseline_m == pytest.approx(0.1)
    assert rectification.rectified.doffs_px == 0.0
    rng = np.random.default_rng(0)
    image = rng.integers(0, 256, (240, 320, 3), dtype=np.uint8)
    left, right = rectification.apply(image, image)
    assert left.shape == image.shape and left.dtype == np.uint8
    assert np.array_equal(left[2:-2, 2:-2], image[2:-2, 2:-2])
    with pytest.raises(ImageMismatchError, match="320x240"):
        rectification.apply(image[:100], image)


def test_ground_truth_mapping_is_identity_for_an_ideal_rig(synthetic):
    pair, calibration, _ = synthetic
    k = calibration.camera_matrix_left
    ideal = CameraPairCalibration(k, None, k, None, np.eye(3), [-0.12, 0, 0], *calibration.image_size)
    truth = rectified_ground_truth(rectify_calibration(ideal), pair.depth, pair.nonocc, camera_matrix_left=k,
                                   camera_matrix_right=k, rotation=np.eye(3), translation_m=[-0.12, 0, 0])
    both = np.isfinite(truth.disparity)
    assert both.mean() > 0.6
    assert np.allclose(truth.disparity[both], pair.disparity[both], atol=1e-3)
    assert truth.vertical.max_px < 1e-3


def test_calibrated_rectification_of_the_synthetic_pair(synthetic):
    pair, calibration, rectification = synthetic
    before = check_rectification(pair.left, pair.right, warn=False)
    assert before.offsets.median_px > 2.0 and before.rectified is False
    left, right = rectification.apply(pair.left, pair.right)
    truth = rectified_ground_truth(rectification, pair.depth, pair.nonocc, **truth_kwargs(calibration))
    assert truth.vertical.n_points > 30000
    assert truth.vertical.p95_px < 0.1  # exact correspondences
    after = check_rectification(left, right, warn=False)
    assert after.rectified is True and after.offsets.median_px < 0.3  # SIFT localisation noise included
    rectified = evaluate_disparity(match(left, right).disparity, truth.disparity, mask=truth.nonocc)
    unrectified = evaluate_disparity(match(pair.left, pair.right).disparity, pair.disparity, mask=pair.nonocc)
    assert rectified.density_pct > 65 and rectified.bad1_matched_pct < 10
    assert unrectified.density_pct < 30 and unrectified.bad1_matched_pct > 50


def test_points_follow_the_maps(synthetic):
    _, _, rectification = synthetic
    maps = rectification.maps
    v, u = np.mgrid[20:220:40, 20:300:40]
    source = np.c_[maps.left_x[v, u].ravel(), maps.left_y[v, u].ravel()]
    assert np.allclose(rectification.left_points(source), np.c_[u.ravel(), v.ravel()], atol=0.01)


def test_vertical_offset_stats():
    stats = vertical_offset_stats(np.array([[0, 1.0], [0, 2.0], [0, 3.0]]), np.array([[0, 1.5], [0, 2.0], [0, 1.0]]))
    assert stats.median_px == 0.5 and stats.max_px == 2.0 and stats.n_points == 3
    assert stats.mean_signed_px == pytest.approx(0.5)
    assert vertical_offset_stats(np.zeros((0, 2)), np.zeros((0, 2))).to_dict()["median_px"] is None
    with pytest.raises(ValueError, match="N, 2"):
        vertical_offset_stats(np.zeros((3, 2)), np.zeros((2, 2)))


def test_middlebury_turned_right_camera(shared_dataset):
    from stereo_obstacles.datasets import load_pair

    pair = load_pair(shared_dataset("middlebury2003_cones"))
    right, depth, calibration = perturbed_middlebury(pair.right, pair.gt_disparity)
    rectification = rectify_calibration(calibration)
    left_r, right_r = rectification.apply(pair.left, right)
    truth = rectified_ground_truth(rectification, depth, pair.nonocc, **truth_kwargs(calibration))
    assert truth.vertical.p95_px < 0.1
    assert check_rectification(left_r, right_r, warn=False).offsets.median_px < 0.3
    perfect = evaluate_disparity(match(pair.left, pair.right, max_disparity=60).disparity, pair.gt_disparity,
                                 mask=pair.nonocc)
    rectified = evaluate_disparity(match(left_r, right_r, max_disparity=60).disparity, truth.disparity,
                                   mask=truth.nonocc)
    assert rectified.bad1_matched_pct < perfect.bad1_matched_pct + 1.5
    assert rectified.density_pct > perfect.density_pct - 10


def test_a_length_unit_for_a_camera_calibration_json_is_not_used_and_said_so(tmp_path, caplog):
    write_camera_pair_json(tmp_path / "rig.json", IDEAL)
    loaded = read_camera_calibration(tmp_path / "rig.json", length_unit="cm")
    np.testing.assert_allclose(loaded.translation_m, IDEAL.translation_m)
    assert "the length unit 'cm' (--calib-unit) is not used" in caplog.text
    assert "a camera calibration of this tool, in metres" in caplog.text


def test_an_opencv_camera_calibration_in_millimetres_is_read_with_its_unit(tmp_path):
    # T = -120 (mm): read with the unit it is a 0.12 m rig; without it, refused with a hint
    in_mm = CameraPairCalibration(K, None, K, None, np.eye(3), [-0.12, 0.0, 0.0], 320, 240)
    write_opencv_yaml(tmp_path / "pair.yml", in_mm)
    text = (tmp_path / "pair.yml").read_text()
    (tmp_path / "pair.yml").write_text(text.replace("data: [ -0.12, 0., 0. ]", "data: [ -120., 0., 0. ]"))
    assert "-120." in (tmp_path / "pair.yml").read_text()
    loaded = read_camera_calibration(tmp_path / "pair.yml", length_unit="mm")
    np.testing.assert_allclose(loaded.translation_m, [-0.12, 0.0, 0.0])
    assert loaded.baseline_m == pytest.approx(0.12)
    with pytest.raises(CalibrationError, match="pair.yml: the baseline is 120 in the file's length unit, "
                                               "implausible in metres; .* give it \\(--calib-unit mm or cm"):
        read_camera_calibration(tmp_path / "pair.yml")
