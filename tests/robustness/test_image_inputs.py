"""Missing, empty, broken and odd image files through detect, disparity and segment."""

from __future__ import annotations

import json

import numpy as np
import pytest

from robustness._inputs import error_line

BAD_FILES = [
    ("missing.png", "image {f} does not exist"),
    ("empty.png", "image {f} is empty"),
    ("truncated.png", "{f} is not an image OpenCV can decode"),
    ("text.png", "{f} is not an image OpenCV can decode"),
    ("huge_header.png", "{f} cannot be decoded: its header claims a size beyond OpenCV's decoding limit"),
]


@pytest.mark.parametrize("name, message", BAD_FILES)
@pytest.mark.parametrize("command", ["detect", "disparity", "segment"])
def test_a_bad_image_file_is_one_line_naming_it(inputs, run_cli, tmp_path, command, name, message):
    bad = inputs / name
    args = {"detect": ["detect", bad, inputs / "right.png", "--out", tmp_path / "out"],
            "disparity": ["disparity", bad, inputs / "right.png", "-o", tmp_path / "d.npy"],
            "segment": ["segment", bad, "-o", tmp_path / "labels.png"]}[command]
    code, _, err, _ = run_cli(*args)
    assert code == 1
    assert message.format(f=bad) in error_line(err)
    assert list(tmp_path.iterdir()) == []


def test_a_folder_given_as_image_is_named(inputs, run_cli, tmp_path):
    code, _, err, _ = run_cli("detect", inputs, inputs / "right.png", "--out", tmp_path / "out")
    assert code == 1 and f"image {inputs} is a folder, not a file" in error_line(err)


def test_images_of_different_sizes_are_refused_with_both_sizes(inputs, run_cli, tmp_path):
    code, _, err, _ = run_cli("detect", inputs / "smaller.png", inputs / "right.png", "--out", tmp_path / "o")
    assert code == 1 and "is 150x100 but" in error_line(err) and "160x120" in error_line(err)
    code, _, err, _ = run_cli("disparity", inputs / "smaller.png", inputs / "right.png", "-o", tmp_path / "d.npy")
    assert code == 1 and "smaller.png is 150x100 but" in error_line(err) and "right.png is 160x120" in error_line(err)


def test_grey_images_are_refused_by_detect_but_matched_by_disparity(inputs, run_cli, tmp_path):
    code, _, err, _ = run_cli("detect", inputs / "grey_left.png", inputs / "grey_right.png", "--out", tmp_path / "o")
    assert code == 1 and "is a grey image; a colour image is needed" in error_line(err)
    code, _, _, _ = run_cli("disparity", inputs / "grey_left.png", inputs / "grey_right.png",
                            "-o", tmp_path / "d.npy")
    assert code == 0 and np.isfinite(np.load(tmp_path / "d.npy")).mean() > 0.3


@pytest.mark.parametrize("left, right", [("left16.png", "right16.png"), ("left_rgba.png", "right_rgba.png"),
                                         ("palette_left.png", "palette_right.png")])
def test_16_bit_4_channel_and_palette_pairs_are_detected(inputs, run_cli, tmp_path, left, right):
    code, out, _, _ = run_cli("detect", inputs / left, inputs / right, "--out", tmp_path / "o",
                              "--calib", inputs / "scene" / "calibration.json")
    assert code == 0
    report = json.loads((tmp_path / "o" / "obstacles.json").read_text())
    assert "obstacles" in report and (tmp_path / "o" / "index.html").is_file()


def test_a_16_bit_pair_gives_the_8_bit_pairs_disparity(inputs, run_cli, tmp_path):
    assert run_cli("disparity", inputs / "left.png", inputs / "right.png", "-o", tmp_path / "a.npy")[0] == 0
    assert run_cli("disparity", inputs / "left16.png", inputs / "right16.png", "-o", tmp_path / "b.npy")[0] == 0
    a, b = np.load(tmp_path / "a.npy"), np.load(tmp_path / "b.npy")
    both = np.isfinite(a) & np.isfinite(b)
    assert both.mean() > 0.3 and np.median(np.abs(a[both] - b[both])) < 0.25


def test_mixed_bit_depths_are_refused(inputs, run_cli, tmp_path):
    code, _, err, _ = run_cli("detect", inputs / "left16.png", inputs / "right.png", "--out", tmp_path / "o")
    assert code == 1 and "is uint16 but" in error_line(err)


@pytest.mark.parametrize("side", [1, 4])
def test_images_smaller_than_the_window_are_refused(inputs, run_cli, tmp_path, side):
    code, _, err, _ = run_cli("disparity", inputs / f"tiny{side}_left.png", inputs / f"tiny{side}_right.png",
                              "-o", tmp_path / "d.npy")
    assert code == 1 and "at least 5x5 pixels" in error_line(err)
    code, _, err, _ = run_cli("detect", inputs / f"tiny{side}_left.png", inputs / f"tiny{side}_right.png",
                              "--out", tmp_path / "o")
    assert code == 1 and "at least 5x5 pixels" in error_line(err)   # the matcher runs first


def test_a_window_sized_pair_matches_without_crashing(inputs, run_cli, tmp_path):
    code, _, _, _ = run_cli("disparity", inputs / "tiny5_left.png", inputs / "tiny5_right.png",
                            "-o", tmp_path / "d.npy")
    assert code == 0 and np.load(tmp_path / "d.npy").shape == (5, 5)


def test_a_very_wide_image_matches(run_cli, tmp_path):
    import cv2

    rng = np.random.default_rng(3)
    right = rng.integers(0, 256, (8, 6000), dtype=np.uint8)
    left = np.roll(right, 7, axis=1)
    cv2.imwrite(str(tmp_path / "l.png"), left)
    cv2.imwrite(str(tmp_path / "r.png"), right)
    code, out, _, _ = run_cli("disparity", tmp_path / "l.png", tmp_path / "r.png", "-o", tmp_path / "d.npy",
                              "--max-disparity", "20", "--json")
    assert code == 0
    d = np.load(tmp_path / "d.npy")
    assert d.shape == (8, 6000) and np.nanmedian(d) == pytest.approx(7, abs=0.25)

