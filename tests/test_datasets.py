"""Dataset layouts: the shared real data, and small synthetic folders for the official layouts."""

from __future__ import annotations

import json

import numpy as np
import pytest

from stereo_obstacles.calibration import StereoCalibration, write_calibration_json
from stereo_obstacles.datasets import StereoPair, list_frames, load_pair
from stereo_obstacles.errors import (CalibrationError, ImageMismatchError, InputFileError,
                                     InvalidInputError)
from stereo_obstacles.fileio import write_image, write_kitti_disparity, write_pfm

# --- the shared data (ranges from each folder's README) --------------------------------------

SHARED = [
    # folder, layout, (W, H), gt min, gt max, has nonocc
    ("middlebury2001_tsukuba", "middlebury-v2", (384, 288), 5.0, 14.0, True),
    ("middlebury2001_venus", "middlebury-v2", (434, 383), 3.0, 19.75, True),
    ("middlebury2003_teddy", "middlebury-v2", (450, 375), 12.5, 52.75, True),
    ("middlebury2003_cones", "middlebury-v2", (450, 375), 5.5, 55.0, True),
    ("opencv_aloe", "opencv-sample", (1282, 1110), 43.0, 211.0, False),
    ("kitti2015_000005", "kitti-pair", (1242, 375), 4.74, 101.2, False),
    ("kitti2015_000045", "kitti-pair", (1242, 375), 4.88, 89.36, False),
    ("kitti2015_000046", "kitti-pair", (1242, 375), 4.87, 65.74, False),
]


@pytest.mark.shared_data
@pytest.mark.parametrize(("name", "layout", "size", "gt_min", "gt_max", "has_mask"), SHARED)
def test_shared_datasets_decode_with_the_documented_scale(shared_dataset, name, layout, size,
                                                          gt_min, gt_max, has_mask):
    pair = load_pair(shared_dataset(name))
    assert pair.layout == layout and pair.name == name
    assert pair.left.shape == (size[1], size[0], 3) and pair.left.dtype == np.uint8
    assert pair.gt_disparity.dtype == np.float32
    assert float(np.nanmin(pair.gt_disparity)) == pytest.approx(gt_min, abs=0.01)
    assert pair.max_gt_disparity == pytest.approx(gt_max, abs=0.01)
    assert (pair.nonocc is not None) == has_mask
    if has_mask:
        assert not np.any(pair.nonocc & np.isnan(pair.gt_disparity))
        assert 0.7 < pair.nonocc.mean() < 0.95
    assert pair.is_kitti == name.startswith("kitti")


@pytest.mark.shared_data
def test_shared_gt_matches_the_images_photometrically(shared_dataset):
    """Warping the right image by the decoded GT beats zero disparity by far (scale check)."""
    pair = load_pair(shared_dataset("middlebury2001_tsukuba"))
    grey_l = pair.left.mean(axis=2)
    grey_r = pair.right.mean(axis=2)
    ys, xs = np.nonzero(pair.nonocc)
    xr = np.rint(xs - pair.gt_disparity[ys, xs]).astype(int)
    err_gt = np.abs(grey_l[ys, xs] - grey_r[ys, xr]).mean()
    err_zero = np.abs(grey_l[ys, xs] - grey_r[ys, xs]).mean()
    assert err_gt < 0.4 * err_zero


@pytest.mark.shared_data
def test_shared_kitti_calibration(shared_dataset):
    pair = load_pair(shared_dataset("kitti2015_000005"))
    cal = pair.calibration
    assert cal.focal_px == pytest.approx(721.5377)
    assert cal.baseline_m == pytest.approx(0.5327, abs=1e-3)
    assert (cal.cx_px, cal.cy_px) == pytest.approx((609.5593, 172.854))
    assert (cal.width_px, cal.height_px) == (1242, 375)


@pytest.mark.shared_data
def test_folders_without_a_pair_are_refused_by_name(shared_dataset):
    folder = shared_dataset("calibration_examples")
    with pytest.raises(InputFileError, match="calibration_examples: no stereo pair layout"):
        load_pair(folder)


# --- synthetic fixtures for the official layouts ----------------------------------------------

def _images(folder, left_name, right_name, size, grey=False, seed=0):
    rng = np.random.default_rng(seed)
    w, h = size
    shape = (h, w) if grey else (h, w, 3)
    left = rng.integers(0, 256, shape, dtype=np.uint8)
    right = rng.integers(0, 256, shape, dtype=np.uint8)
    folder.mkdir(parents=True, exist_ok=True)
    write_image(folder / left_name, left)
    write_image(folder / right_name, right)
    return left, right


def _gt8(folder, name, size, values):
    """An 8-bit GT image filled with ``values`` (row-wise pattern), 0 in the first column."""
    w, h = size
    raw = np.tile(np.asarray(values, dtype=np.uint8), (h, w // len(values) + 1))[:, :w]
    raw[:, 0] = 0
    write_image(folder / name, np.ascontiguousarray(raw))
    return raw


def test_middlebury2001_official_layout_uses_scale_8(tmp_path):
    size = (434, 383)
    left, _ = _images(tmp_path, "im2.ppm", "im6.ppm", size)
    raw = _gt8(tmp_path, "disp2.pgm", size, [80, 160])
    pair = load_pair(tmp_path)
    assert pair.layout == "middlebury2001"
    np.testing.assert_array_equal(pair.left, left)
    np.testing.assert_allclose(pair.gt_disparity[:, 1:], raw[:, 1:] / 8.0)
    assert np.all(np.isnan(pair.gt_disparity[:, 0]))
    assert pair.nonocc is None


def test_tsukuba_original_names_use_scale_16(tmp_path):
    size = (384, 288)
    _images(tmp_path, "scene1.row3.col3.ppm", "scene1.row3.col4.ppm", size)
    raw = _gt8(tmp_path, "truedisp.row3.col3.pgm", size, [80, 224])
    mask = np.zeros((288, 384), np.uint8)
    mask[10:-10, 10:-10] = 255
    write_image(tmp_path / "nonocc.png", mask)
    pair = load_pair(tmp_path)
    assert pair.layout == "middlebury2001"
    np.testing.assert_allclose(pair.gt_disparity[:, 1:], raw[:, 1:] / 16.0)
    assert pair.nonocc[20, 20] and not pair.nonocc[5, 5]


@pytest.mark.parametrize(("size", "scale"), [((450, 375), 4), ((900, 750), 2)])
def test_middlebury2003_scale_follows_the_image_size(tmp_path, size, scale):
    _images(tmp_path, "im2.png", "im6.png", size)
    raw = _gt8(tmp_path, "disp2.png", size, [100, 200])
    pair = load_pair(tmp_path)
    assert pair.layout == "middlebury2003"
    np.testing.assert_allclose(pair.gt_disparity[:, 1:], raw[:, 1:] / scale)


def test_gt_scale_override(tmp_path):
    size = (434, 383)
    _images(tmp_path, "im2.png", "im6.png", size)
    raw = _gt8(tmp_path, "disp2.png", size, [100])
    pair = load_pair(tmp_path, gt_scale=2)
    np.testing.assert_allclose(pair.gt_disparity[:, 1:], raw[:, 1:] / 2.0)
    with pytest.raises(InvalidInputError, match="gt_scale"):
        load_pair(tmp_path, gt_scale=0)


def test_unknown_middlebury_size_asks_for_the_scale(tmp_path):
    _images(tmp_path, "im2.png", "im6.png", (600, 500))
    _gt8(tmp_path, "disp2.png", (600, 500), [100])
    with pytest.raises(InputFileError, match="pass gt_scale"):
        load_pair(tmp_path)


@pytest.mark.parametrize(("width", "scale"), [(1390, 1), (695, 2), (463, 3)])
def test_middlebury2005_scale_by_width_and_lr_check_mask(tmp_path, width, scale):
    size = (width, 40)
    _images(tmp_path, "view1.png", "view5.png", size)
    d = 10  # true disparity in pixels, everywhere
    left_gt = np.full((40, width), d * scale, np.uint8)
    right_gt = np.full((40, width), d * scale, np.uint8)
    right_gt[:, 100:110] = 30 * scale  # a closer surface in the right view: occludes left 110..119
    write_image(tmp_path / "disp1.png", left_gt)
    write_image(tmp_path / "disp5.png", right_gt)
    pair = load_pair(tmp_path)
    assert pair.layout == "middlebury2005"
    np.testing.assert_allclose(pair.gt_disparity, d)
    assert not pair.nonocc[:, :d].any()           # x - d falls outside the right image
    assert not pair.nonocc[:, 110:120].any()      # seen closer in the right view: occluded
    assert pair.nonocc[:, 120:].all() and pair.nonocc[:, d:110].all()


def test_middlebury2014_layout_with_calibration_and_mask(tmp_path):
    size = (64, 48)
    _images(tmp_path, "im0.png", "im1.png", size)
    gt = np.full((48, 64), 12.25, np.float32)
    gt[0, 0] = np.nan
    write_pfm(tmp_path / "disp0GT.pfm", gt)
    mask = np.full((48, 64), 255, np.uint8)
    mask[:, :5] = 128  # occluded
    write_image(tmp_path / "mask0nocc.png", mask)
    (tmp_path / "calib.txt").write_text(
        "cam0=[500.5 0 30.25; 0 500.5 22.5; 0 0 1]\ncam1=[500.5 0 40.25; 0 500.5 22.5; 0 0 1]\n"
        "doffs=10\nbaseline=120.5\nwidth=64\nheight=48\nndisp=30\n")
    pair = load_pair(tmp_path)
    assert pair.layout == "middlebury2014"
    assert np.isnan(pair.gt_disparity[0, 0]) and pair.gt_disparity[5, 5] == 12.25
    assert not pair.nonocc[:, :5].any() and pair.nonocc[1:, 5:].all() and not pair.nonocc[0, 0]
    cal = pair.calibration
    assert (cal.focal_px, cal.cx_px, cal.cy_px, cal.doffs_px) == (500.5, 30.25, 22.5, 10.0)
    assert cal.baseline_m == pytest.approx(0.1205)


def test_middlebury2014_calibration_for_another_size_is_an_error(tmp_path):
    _images(tmp_path, "im0.png", "im1.png", (64, 48))
    (tmp_path / "calib.txt").write_text(
        "cam0=[500 0 30; 0 500 22; 0 0 1]\ncam1=[500 0 30; 0 500 22; 0 0 1]\n"
        "doffs=0\nbaseline=100\nwidth=128\nheight=96\n")
    with pytest.raises(CalibrationError, match="128x96"):
        load_pair(tmp_path)


@pytest.mark.parametrize("text", ["cam0=[garbage\n", "cam0=[500 0 30; 0 500 22; 0 0 1]\ncam1=[500 0 30; 0 500 22; "
                                  "0 0 1]\ndoffs=0\nbaseline=100\nwidth=128\nheight=96\n"])
def test_a_caller_with_its_own_calibration_is_not_failed_by_the_folders(tmp_path, text):
    _images(tmp_path, "im0.png", "im1.png", (64, 48))
    (tmp_path / "calib.txt").write_text(text)                          # broken, or for other images
    with pytest.raises(CalibrationError):
        load_pair(tmp_path)
    pair = load_pair(tmp_path, with_calibration=False)
    assert pair.layout == "middlebury2014" and pair.left.shape == (48, 64, 3)
    assert pair.calibration is None and pair.calibration_file == tmp_path / "calib.txt"


def _kitti_calib_text():
    return ("calib_time: 09-Jan-2012 13:57:47\n"
            "P_rect_02: 7.2e+02 0 6.0e+02 4.5e+01 0 7.2e+02 1.7e+02 0 0 0 1 0\n"
            "P_rect_03: 7.2e+02 0 6.0e+02 -3.4e+02 0 7.2e+02 1.7e+02 0 0 0 1 0\n")


def test_kitti2015_layout_frames_gt_mask_and_calibration(tmp_path):
    size = (80, 30)
    for frame in ("000001_10", "000000_10"):
        _images(tmp_path / "image_2", f"{frame}.png", "unused.png", size)
        _images(tmp_path / "image_3", f"{frame}.png", "unused.png", size)
    occ = np.full((30, 80), 20.5, np.float32)
    noc = occ.copy()
    noc[:, :10] = np.nan
    (tmp_path / "disp_occ_0").mkdir()
    (tmp_path / "disp_noc_0").mkdir()
    write_kitti_disparity(tmp_path / "disp_occ_0" / "000001_10.png", occ)
    write_kitti_disparity(tmp_path / "disp_noc_0" / "000001_10.png", noc)
    (tmp_path / "calib_cam_to_cam").mkdir()
    (tmp_path / "calib_cam_to_cam" / "000001.txt").write_text(_kitti_calib_text())
    assert list_frames(tmp_path) == ("000000_10", "000001_10")
    pair = load_pair(tmp_path, frame="000001_10")
    assert pair.layout == "kitti2015" and pair.is_kitti
    assert pair.name.endswith("/000001_10")
    np.testing.assert_allclose(pair.gt_disparity, 20.5)
    assert not pair.nonocc[:, :10].any() and pair.nonocc[:, 10:].all()
    assert pair.calibration.baseline_m == pytest.approx(385 / 720)
    assert (pair.left_file, pair.right_file, pair.calibration_file) == (
        tmp_path / "image_2" / "000001_10.png", tmp_path / "image_3" / "000001_10.png",
        tmp_path / "calib_cam_to_cam" / "000001.txt")
    bare = load_pair(tmp_path, frame="000000_10")
    assert bare.gt_disparity is None and bare.calibration is None and bare.calibration_file is None
    with pytest.raises(InvalidInputError, match="pass frame"):
        load_pair(tmp_path)
    with pytest.raises(InputFileError, match="000009_10"):
        load_pair(tmp_path, frame="000009_10")


def test_synthetic_scene_folder(tmp_path):
    size = (40, 30)
    _images(tmp_path, "left.png", "right.png", size)
    gt = np.full((30, 40), 7.5, np.float32)
    write_pfm(tmp_path / "disparity.pfm", gt)
    write_image(tmp_path / "nonocc.png", np.full((30, 40), 255, np.uint8))
    cal = StereoCalibration(focal_px=100.0, cx_px=20.0, cy_px=15.0, baseline_m=0.1,
                            width_px=40, height_px=30)
    write_calibration_json(tmp_path / "calibration.json", cal)
    pair = load_pair(tmp_path)
    assert pair.layout == "synthetic" and pair.calibration == cal
    assert pair.nonocc.all() and pair.max_gt_disparity == 7.5
    assert json.loads((tmp_path / "calibration.json").read_text())["focal_px"] == 100.0


def test_grey_images_become_three_channels(tmp_path):
    left, _ = _images(tmp_path, "left.png", "right.png", (20, 10), grey=True)
    pair = load_pair(tmp_path)
    assert pair.left.shape == (10, 20, 3)
    np.testing.assert_array_equal(pair.left[:, :, 2], left)
    assert pair.gt_disparity is None and pair.max_gt_disparity is None


def test_images_of_different_sizes(tmp_path):
    write_image(tmp_path / "left.png", np.zeros((10, 20, 3), np.uint8))
    write_image(tmp_path / "right.png", np.zeros((10, 21, 3), np.uint8))
    with pytest.raises(ImageMismatchError, match="right image is 21x10"):
        load_pair(tmp_path)


def test_gt_of_another_size(tmp_path):
    _images(tmp_path, "left.png", "right.png", (20, 10))
    write_pfm(tmp_path / "disparity.pfm", np.zeros((10, 19), np.float32))
    with pytest.raises(ImageMismatchError, match="ground truth is 19x10"):
        load_pair(tmp_path)


def test_missing_and_unrecognised_folders(tmp_path):
    with pytest.raises(InputFileError, match="does not exist"):
        load_pair(tmp_path / "nope")
    (tmp_path / "a.txt").write_text("x")
    with pytest.raises(InputFileError, match="is not a folder"):
        load_pair(tmp_path / "a.txt")
    with pytest.raises(InputFileError, match="no stereo pair layout"):
        load_pair(tmp_path)


def test_kitti_pair_without_its_right_image(tmp_path):
    write_image(tmp_path / "000001_10_left.png", np.zeros((10, 20, 3), np.uint8))
    with pytest.raises(InputFileError, match="000001_10_right.png is missing"):
        load_pair(tmp_path)


def test_id_left_id_right_pair_of_another_image_format_without_ground_truth(tmp_path):
    _images(tmp_path, "teddy_left.ppm", "teddy_right.ppm", (20, 10))
    pair = load_pair(tmp_path)
    assert pair.layout == "kitti-pair" and pair.left.shape == (10, 20, 3) and pair.gt_disparity is None
    _images(tmp_path, "other_left.ppm", "other_right.ppm", (20, 10))
    with pytest.raises(InputFileError, match="several \\*_left images"):
        load_pair(tmp_path)


@pytest.mark.parametrize("scale", ["16", True, float("nan"), 0])
def test_a_ground_truth_scale_that_is_not_a_positive_number_is_refused(tmp_path, scale):
    _images(tmp_path, "left.png", "right.png", (20, 10))
    with pytest.raises(InvalidInputError, match="gt_scale must be a finite number > 0"):
        load_pair(tmp_path, gt_scale=scale)


def test_a_numpy_number_is_a_ground_truth_scale(tmp_path):
    _images(tmp_path, "left.png", "right.png", (20, 10))
    assert load_pair(tmp_path, gt_scale=np.float32(16)).left.shape == (10, 20, 3)


def test_a_single_pair_folder_refuses_a_frame(tmp_path):
    _images(tmp_path, "left.png", "right.png", (20, 10))
    assert list_frames(tmp_path) == (None,)
    with pytest.raises(InvalidInputError, match="single pair"):
        load_pair(tmp_path, frame="000000_10")


def test_pair_validates_itself(tmp_path):
    image = np.zeros((4, 5, 3), np.uint8)
    with pytest.raises(InvalidInputError, match="uint8"):
        StereoPair(name="x", left=image.astype(np.float32), right=image, gt_disparity=None,
                   nonocc=None, calibration=None, source=tmp_path, layout="synthetic")
    with pytest.raises(ImageMismatchError, match="non-occluded mask"):
        StereoPair(name="x", left=image, right=image, gt_disparity=None,
                   nonocc=np.ones((4, 5), np.uint8), calibration=None, source=tmp_path,
                   layout="synthetic")


def test_scene_command_output_loads(tmp_path):
    from stereo_obstacles.cli import COMMAND_MODULES, main

    if "scene" not in COMMAND_MODULES:
        pytest.skip("the scene command is not available")
    out = tmp_path / "scene"
    assert main(["scene", "--out", str(out), "--size", "160x120"]) == 0
    pair = load_pair(out)
    assert pair.layout == "synthetic" and pair.left.shape == (120, 160, 3)
    assert (pair.calibration.width_px, pair.calibration.height_px) == (160, 120)
    assert pair.nonocc.mean() > 0.5 and not np.any(pair.nonocc & np.isnan(pair.gt_disparity))


def test_a_folder_of_rendered_frames_says_to_name_one(tmp_path):
    # "no stereo pair layout recognised" without frame=, "holds a single pair" with a wrong one (API review)
    from stereo_obstacles.cli import main

    assert main(["scene", "--out", str(tmp_path / "seq"), "--frames", "2", "--size", "160x120"]) == 0
    with pytest.raises(InvalidInputError, match=r"seq holds 2 rendered frames \(frame_0000, ...\): give one frame's "
                                                r"folder \(.*seq/frame_0000\), or frame="):
        load_pair(tmp_path / "seq")
    with pytest.raises(InvalidInputError, match=r"\(frame_0000, ...\), and no frame 'frame_0009': give"):
        load_pair(tmp_path / "seq", frame="frame_0009")
    assert load_pair(tmp_path / "seq", frame="frame_0001").layout == "synthetic"
