"""Scores of the segmentation, the KITTI plane-derived truth, and the two sub-commands."""

from __future__ import annotations

import json

import numpy as np
import pytest

from stereo_obstacles.cli import main
from stereo_obstacles.errors import ImageMismatchError, InvalidInputError
from stereo_obstacles.fileio import read_labels, write_image
from stereo_obstacles.labels import Label
from stereo_obstacles.segmentation_evaluation import (SegmentationCounts, count_segmentation,
                                                      evaluate_synthetic, kitti_truth, total)

G, S, O, M, K, U = (int(v) for v in (Label.GROUND, Label.SHADOW, Label.OBSTACLE, Label.MARKING,
                                     Label.SKY, Label.UNKNOWN))


def test_counts_and_ber_from_the_definition():
    truth = np.array([[O, O, O, O, G, G, S, S, M, K]], dtype=np.uint8)
    said = np.array([[O, O, O, G, G, O, O, S, O, O]], dtype=np.uint8)
    c = count_segmentation(said, truth)
    assert (c.n_obstacle, c.n_ground, c.n_shadow, c.n_marking) == (4, 2, 2, 1)
    assert c.recall == pytest.approx(0.75)
    assert c.ground_specificity == pytest.approx(0.5)          # G kept 1 of 2, S kept 1 of 2
    assert c.ber_percent == pytest.approx(100 * (1 - (0.75 + 0.5) / 2))
    assert c.shadow_to_obstacle_rate == pytest.approx(0.5)
    assert c.marking_to_obstacle_rate == pytest.approx(1.0)


def test_unknown_counts_against_both_classes():
    truth = np.array([[O, G]], dtype=np.uint8)
    c = count_segmentation(np.array([[U, U]], dtype=np.uint8), truth)
    assert c.ber_percent == pytest.approx(100.0) and c.n_unknown == 2


def test_counts_add_and_pool():
    a = SegmentationCounts(n_obstacle=2, obstacle_hit=1)
    b = SegmentationCounts(n_obstacle=2, obstacle_hit=2)
    assert (a + b).recall == pytest.approx(0.75)
    assert np.isnan(SegmentationCounts().recall)


def test_count_rejects_mismatch():
    with pytest.raises(ImageMismatchError, match="shape"):
        count_segmentation(np.zeros((2, 2), np.uint8), np.zeros((2, 3), np.uint8))
    with pytest.raises(InvalidInputError, match="uint8"):
        count_segmentation(np.zeros((2, 2), np.int32), np.zeros((2, 2), np.uint8))


def test_kitti_truth_from_a_plane_with_a_car():
    ys, xs = np.mgrid[0:100, 0:200]
    d = (0.33 * (ys - 30.0) + 0.002 * xs).astype(np.float32)   # road, horizon at row 30
    d[d < 0.5] = np.nan                                          # nothing measured above it
    d[50:80, 60:120] = 30.0                                      # a car, clearly in front
    d[::3, ::2] = np.nan                                         # sparse LiDAR
    labels, plane = kitti_truth(d)
    assert plane.b == pytest.approx(0.33, abs=1e-3)
    assert np.all(labels[85:, :][np.isfinite(d[85:, :])] == Label.GROUND)
    car = labels[52:78, 62:118][np.isfinite(d[52:78, 62:118])]
    assert np.mean(car == Label.OBSTACLE) > 0.95
    assert np.all(labels[np.isnan(d)] == Label.UNKNOWN)


def test_synthetic_scene_scores_show_the_ablation():
    scores = evaluate_synthetic([7], width_px=160, height_px=120)     # lit reference, shadows ahead
    on, off = total(scores), total(scores, rule=False)
    assert on.n_shadow > 0 and on.n_obstacle > 0
    assert off.shadow_to_obstacle_rate > on.shadow_to_obstacle_rate + 0.2
    assert 0.0 <= on.ber_percent <= 100.0


def test_segment_command_writes_labels_overlay_and_record(tmp_path, capsys):
    rng = np.random.default_rng(0)
    image = np.clip(rng.normal((90, 140, 60), 3.0, (60, 80, 3)), 0, 255).astype(np.uint8)
    image[10:25, 30:45] = (200, 40, 40)
    write_image(tmp_path / "in.png", image)
    out = tmp_path / "labels.png"
    code = main(["segment", str(tmp_path / "in.png"), "-o", str(out), "--overlay",
                 str(tmp_path / "overlay.png"), "--reference", "0.3,0.8,0.7,1"])
    assert code == 0
    labels = read_labels(out)
    assert labels[15, 35] == Label.OBSTACLE and labels[50, 10] == Label.GROUND
    assert (tmp_path / "overlay.png").is_file()
    record = json.loads((tmp_path / "labels.png.json").read_text())
    assert record["reference"]["box_px"] == [24, 48, 56, 60]
    said = capsys.readouterr().out
    assert said.startswith(f"wrote {out}: ground ") and "obstacle" in said


def test_segment_command_replaces_its_own_record_not_a_users_file(tmp_path, capsys):
    rng = np.random.default_rng(0)
    write_image(tmp_path / "in.png", np.clip(rng.normal((90, 140, 60), 3.0, (60, 80, 3)), 0, 255).astype(np.uint8))
    args = ["segment", str(tmp_path / "in.png"), "-o", str(tmp_path / "labels.png")]
    notes = tmp_path / "labels.png.json"
    notes.write_text("my notes\n")
    assert main(args) == 1
    assert "labels.png.json exists and is not a segmentation record of this tool" in capsys.readouterr().err
    assert notes.read_text() == "my notes\n" and not (tmp_path / "labels.png").exists()
    notes.unlink()
    assert main(args) == 0 and main(args) == 0                     # its own record is replaced
    assert json.loads(notes.read_text())["format"] == "stereo-obstacles/segmentation"
    legacy = json.loads(notes.read_text())
    del legacy["format"]                                           # as written before the record had one
    notes.write_text(json.dumps(legacy))
    assert main(args) == 0


def test_segment_command_reads_a_12_bit_image_by_its_significant_bits(tmp_path):
    """A 12-bit image in a 16-bit PNG (values up to 4080) is labelled as its 8-bit copy, as detect
    reads it (taken as 16-bit, its reference area was too dark to use)."""
    import cv2

    rng = np.random.default_rng(0)
    image = np.clip(rng.normal((90, 140, 60), 3.0, (60, 80, 3)), 0, 255).astype(np.uint8)
    image[10:25, 30:45] = (200, 40, 40)
    write_image(tmp_path / "eight.png", image)
    cv2.imwrite(str(tmp_path / "twelve.png"), cv2.cvtColor(image, cv2.COLOR_RGB2BGR).astype(np.uint16) * 16)
    for name in ("eight", "twelve"):
        assert main(["segment", str(tmp_path / f"{name}.png"), "-o", str(tmp_path / f"{name}_labels.png"),
                     "--overlay", str(tmp_path / f"{name}_overlay.png")]) == 0
    np.testing.assert_array_equal(read_labels(tmp_path / "twelve_labels.png"), read_labels(tmp_path / "eight_labels.png"))
    assert np.array_equal(cv2.imread(str(tmp_path / "twelve_overlay.png")), cv2.imread(str(tmp_path / "eight_overlay.png")))


def test_segment_command_reads_a_12_bit_pair_with_the_right_image_as_its_8_bit_copy(tmp_path):
    import cv2

    from stereo_obstacles.synthetic import default_scene, render_pair

    pair = render_pair(default_scene(320, 240))
    for side, image in (("left", pair.left), ("right", pair.right)):
        write_image(tmp_path / f"{side}8.png", image)
        cv2.imwrite(str(tmp_path / f"{side}12.png"), cv2.cvtColor(image, cv2.COLOR_RGB2BGR).astype(np.uint16) * 16)
    for bits in ("8", "12"):
        assert main(["segment", str(tmp_path / f"left{bits}.png"), "--right", str(tmp_path / f"right{bits}.png"),
                     "-o", str(tmp_path / f"labels{bits}.png")]) == 0
    np.testing.assert_array_equal(read_labels(tmp_path / "labels12.png"), read_labels(tmp_path / "labels8.png"))


def test_segment_command_reports_a_bad_reference(tmp_path, capsys):
    write_image(tmp_path / "in.png", np.full((20, 20, 3), (4, 2, 1), np.uint8))   # too dark
    code = main(["segment", str(tmp_path / "in.png"), "-o", str(tmp_path / "l.png")])
    assert code == 1
    assert "unusable" in capsys.readouterr().err
    assert not (tmp_path / "l.png").exists()


def test_evaluate_segmentation_command_json(tmp_path, capsys):
    code = main(["evaluate-segmentation", "--scenes", "1", "--first-seed", "3", "--size", "160x120",
                 "--json", str(tmp_path / "r.json")])
    assert code == 0
    assert "| all | 1 | on |" in capsys.readouterr().out
    def strict(constant):
        raise ValueError(f"{constant} is not JSON")          # Python reads NaN, other parsers do not

    report = json.loads((tmp_path / "r.json").read_text(), parse_constant=strict)
    assert report["synthetic"][0]["name"] == "synthetic-3"


@pytest.mark.shared_data
def test_kitti_truth_on_real_frame(shared_dataset):
    from stereo_obstacles.datasets import load_pair

    pair = load_pair(shared_dataset("kitti2015_000046"))
    labels, plane = kitti_truth(pair.gt_disparity)
    assert plane.b == pytest.approx(0.33, abs=0.05)              # B / h = 0.54 / 1.65
    assert np.count_nonzero(labels == Label.GROUND) > 10000
    assert np.count_nonzero(labels == Label.OBSTACLE) > 10000


@pytest.mark.shared_data
def test_evaluate_segmentation_dataset_option_and_its_old_name(shared_dataset, capsys):
    folder = str(shared_dataset("kitti2015_000046"))
    assert main(["evaluate-segmentation", "--scenes", "0", "--dataset", folder]) == 0
    new = capsys.readouterr().out
    assert "| kitti2015_000046 | 1 | on |" in new
    assert main(["evaluate-segmentation", "--scenes", "0", "--kitti", folder]) == 0
    assert capsys.readouterr().out == new


@pytest.mark.shared_data
def test_a_kitti_frame_is_scored_beside_a_calibration_that_does_not_parse(shared_dataset, tmp_path, capsys):
    # the labels come from the ground-truth disparity alone; the broken file failed the run (review, session 23)
    kitti = shared_dataset("kitti2015_000046")
    folder = tmp_path / "kitti"
    folder.mkdir()
    for name in ("000046_10_left.png", "000046_10_right.png", "000046_10_disp_occ_0.png"):
        (folder / name).symlink_to(kitti / name)
    (folder / "Calib.txt").write_text("P_rect_02: garbage\n")
    assert main(["evaluate-segmentation", "--scenes", "0", "--dataset", str(folder)]) == 0, capsys.readouterr().err


def test_segment_command_colour_model_option(tmp_path):
    rng = np.random.default_rng(0)
    image = np.clip(rng.normal((90, 140, 60), 3.0, (60, 80, 3)), 0, 255).astype(np.uint8)
    image[10:25, 30:45] = (200, 40, 40)
    write_image(tmp_path / "in.png", image)
    for model in ("hsi", "log_rgb"):
        out = tmp_path / f"{model}.png"
        assert main(["segment", str(tmp_path / "in.png"), "-o", str(out), "--colour-model", model]) == 0
        labels = read_labels(out)
        assert labels[15, 35] == Label.OBSTACLE and labels[50, 10] == Label.GROUND
        assert json.loads((tmp_path / f"{model}.png.json").read_text())["colour_model"] == model


@pytest.mark.parametrize("field, bad", [("fit_rows_from", 1.0), ("fit_rows_from", "0.5"),
                                        ("ground_tolerance_px", -1.0), ("obstacle_margin_fraction", None)])
def test_kitti_truth_parameters_are_checked(field, bad):
    from stereo_obstacles.segmentation_evaluation import KittiTruthParameters

    with pytest.raises(InvalidInputError, match=field):
        KittiTruthParameters(**{field: bad})
