"""Outputs that would replace an input, empty output paths, stale files of an earlier run, and
calibrations that parse but cannot be meant (session 16's adversarial review)."""

from __future__ import annotations

import shutil

import pytest

from robustness._inputs import error_line

KITTI = ("P_rect_02: {f} 0 80 0 0 {f} 60 0 0 0 1 0\n"
         "P_rect_03: {f3} 0 80 {tx} 0 {f} {cy3} 0 0 0 1 0\n")


def test_an_output_that_names_an_input_is_refused_before_any_work(inputs, run_cli, tmp_path):
    left, right = tmp_path / "l.png", tmp_path / "r.png"
    shutil.copy(inputs / "left.png", left)
    shutil.copy(inputs / "right.png", right)
    before = left.read_bytes()
    for command in (["disparity", left, right, "-o", left],
                    ["disparity", left, right, "-o", tmp_path / "d.png", "--picture", right],
                    ["disparity", left, right, "-o", tmp_path / "d.png", "--picture", tmp_path / "d.png"],
                    ["segment", left, "-o", left],
                    ["detect", tmp_path / "disparity_picture.png", right, "--out", tmp_path],
                    ["rectify", tmp_path / "left.png", right, "--uncalibrated", "--out", tmp_path]):
        if command[0] in ("detect", "rectify"):
            shutil.copy(inputs / "left.png", command[1])
        code, _, err, _ = run_cli(*command)
        assert code == 1 and "is also an input or another output of this run" in error_line(err), command
    assert left.read_bytes() == before and not (tmp_path / "d.png").exists()


def test_video_outputs_that_would_replace_its_inputs_are_refused(inputs, run_cli, tmp_path):
    for side in ("left", "right"):
        (tmp_path / side).mkdir()
        shutil.copy(inputs / f"{side}.png", tmp_path / side / "0000.png")
    frame = (tmp_path / "left" / "0000.png").read_bytes()
    sources = [tmp_path / "left", tmp_path / "right"]
    for options, message in ((["--jsonl", tmp_path / "left" / "0000.png"], "lies in the input folder"),
                             (["--video-out", tmp_path / "right" / "a.mp4"], "lies in the input folder"),
                             (["--jsonl", tmp_path / "a.x", "--video-out", tmp_path / "a.x"],
                              "is also an input or another output of this run")):
        code, out, err, _ = run_cli("video", *sources, *options)
        assert code == 1 and message in error_line(err) and out == "", options
    assert (tmp_path / "left" / "0000.png").read_bytes() == frame and not (tmp_path / "a.x").exists()


def test_a_failing_output_path_is_found_before_the_first_file_is_written(inputs, run_cli, tmp_path):
    (tmp_path / "file").write_text("not a folder")
    code, _, err, _ = run_cli("disparity", inputs / "left.png", inputs / "right.png", "-o", tmp_path / "d.npy",
                              "--picture", tmp_path / "file" / "p.png")
    assert code == 1 and "is not a folder" in error_line(err)
    assert not (tmp_path / "d.npy").exists()


@pytest.mark.parametrize("command", [["detect", "LEFT", "RIGHT", "--out", ""], ["demo", "--out", " "],
                                     ["disparity", "LEFT", "RIGHT", "-o", ""],
                                     ["evaluate-detection", "--scenes", "1", "--json", ""]])
def test_an_empty_output_path_is_refused(inputs, run_cli, command):
    args = [inputs / "left.png" if a == "LEFT" else inputs / "right.png" if a == "RIGHT" else a for a in command]
    code, _, err, _ = run_cli(*args)
    assert code == 2 and "expected a path to write to" in err


def test_an_uncalibrated_rerun_removes_the_depth_files_of_a_calibrated_run(inputs, run_cli, tmp_path):
    pair = [inputs / "left.png", inputs / "right.png"]
    out = tmp_path / "o"
    assert run_cli("detect", *pair, "--out", out, "--calib", inputs / "scene" / "calibration.json")[0] == 0
    assert (out / "depth.npy").exists() and (out / "points.ply").exists()
    assert run_cli("detect", *pair, "--out", out)[0] == 0
    assert not any((out / name).exists() for name in ("depth.npy", "points.ply", "depth_picture.png"))
    assert (out / "obstacles.json").exists() and (out / "index.html").exists()


@pytest.mark.parametrize("options, message", [
    (["--focal", "700", "--baseline", "1e-9"], "baseline_m = 1e-09 m is implausible"),
    (["--focal", "0.001", "--baseline", "0.12"], "focal_px = 0.001 px is implausible"),
    (["--focal", "138", "--baseline", "0.12", "--cx", "1e9"], "principal point (1e+09, 59.5) px lies far outside"),
    (["--focal", "138", "--baseline", "0.12", "--cy", "-5000"], "principal point (79.5, -5000) px lies far outside"),
])
def test_calibration_values_no_rig_has_are_refused(inputs, run_cli, tmp_path, options, message):
    code, _, err, _ = run_cli("detect", inputs / "left.png", inputs / "right.png", "--out", tmp_path / "o",
                              *options)
    assert code == 1 and message in error_line(err)
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("content, message", [
    ("cam0=[138 0 80; 0 138 60; 0 0 1]\nbaseline=120\n", "lacks 'doffs' and 'cam1'"),
    ("cam0=[138 0 80; 0 138 60; 0 0 1]\ncam1=[138 0 80; 0 138 60; 0 0 1]\nbaseline=0.12\n",
     "metres given where millimetres were expected?"),
    (KITTI.format(f=138, f3=900, tx=-16.56, cy3=60), "differ in their focal length fx (138 and 900)"),
    (KITTI.format(f=138, f3=138, tx=-16.56, cy3=300), "differ in their principal row cy (60 and 300)"),
    (KITTI.format(f=138, f3=138, tx=-16.56, cy3=60) + "P_rect_03: 138 0 80 -1 0 138 60 0 0 0 1 0\n",
     "P_rect_03 is given twice"),
    (KITTI.format(f=138, f3=138, tx="nan", cy3=60), "P_rect_03 holds 'nan', which is not a finite number"),
])
def test_calibration_files_that_cannot_be_meant_are_refused(inputs, run_cli, tmp_path, content, message):
    calib = tmp_path / "calib.txt"
    calib.write_text(content)
    code, _, err, _ = run_cli("detect", inputs / "left.png", inputs / "right.png", "--out", tmp_path / "o",
                              "--calib", calib)
    assert code == 1 and message in error_line(err)


def test_a_max_disparity_that_puts_everything_out_of_reach_is_said(inputs, run_cli, tmp_path):
    code, out, _, log = run_cli("detect", inputs / "left.png", inputs / "right.png", "--out", tmp_path / "o",
                                "--calib", inputs / "scene" / "calibration.json", "--max-disparity", "1",
                                "--max-distance", "10")
    assert code == 0 and "measures nothing nearer than" in log
    code, _, err, _ = run_cli("detect", inputs / "left.png", inputs / "right.png", "--out", tmp_path / "o",
                              "--max-disparity", "-5")
    assert code == 2 and "--max-disparity" in err and "expected a positive integer, got -5" in err


def test_nothing_to_evaluate_and_an_empty_seed_file_are_one_line(inputs, run_cli, tmp_path):
    code, _, err, _ = run_cli("evaluate-detection", "--scenes", "0")
    assert code == 1 and "nothing to evaluate" in error_line(err)
    (tmp_path / "seeds.txt").write_text("")
    code, _, err, _ = run_cli("disparity", inputs / "left.png", inputs / "right.png", "-o", tmp_path / "d.npy",
                              "--seeds", tmp_path / "seeds.txt")
    assert code == 1 and "holds no 'x y d' rows" in error_line(err) and "Warning" not in err


def test_a_pipe_or_a_device_given_as_an_image_is_refused_not_read(inputs, run_cli, tmp_path):
    import os

    os.mkfifo(tmp_path / "pipe.png")
    (tmp_path / "zero.png").symlink_to("/dev/zero")
    for image in (tmp_path / "pipe.png", tmp_path / "zero.png"):
        code, _, err, _ = run_cli("disparity", image, inputs / "right.png", "-o", tmp_path / "d.npy")
        assert code == 1 and "is not a regular file (a pipe or a device?)" in error_line(err)


def test_limits_that_leave_no_true_obstacle_to_score_are_said(run_cli):
    code, out, _, log = run_cli("evaluate-detection", "--scenes", "1", "--size", "64x48", "--supersample", "1",
                                "--min-height", "100")
    assert code == 0 and "0/0 true obstacles" in out and "nothing was scored" in log


def test_evaluation_outputs_inside_a_dataset_folder_are_refused(inputs, run_cli, tmp_path):
    scene = tmp_path / "scene"
    shutil.copytree(inputs / "scene", scene)
    truth = (scene / "disparity.pfm").read_bytes()
    for command in (["evaluate", scene, "--methods", "bm", "--json", scene / "disparity.pfm"],
                    ["evaluate-detection", "--scenes", "0", "--dataset", scene, "--json", scene / "figures.json"],
                    ["evaluate-segmentation", "--scenes", "0", "--dataset", scene, "--json", scene / "left.png"]):
        code, _, err, _ = run_cli(*command)
        assert code == 1 and "lies in the input folder" in error_line(err), command
    assert (scene / "disparity.pfm").read_bytes() == truth and not (scene / "figures.json").exists()


def test_evaluations_check_their_datasets_before_the_scenes(inputs, run_cli, monkeypatch):
    from stereo_obstacles import detection_evaluation, segmentation_evaluation

    def no_scene(*args, **kwargs):
        raise AssertionError("a scene was evaluated before the datasets were checked")

    monkeypatch.setattr(detection_evaluation, "evaluate_synthetic_scene", no_scene)
    monkeypatch.setattr(segmentation_evaluation, "evaluate_synthetic", no_scene)
    code, _, err, _ = run_cli("evaluate-detection", "--scenes", "50", "--dataset", inputs / "nowhere")
    assert code == 1 and "does not exist" in error_line(err)
    code, _, err, _ = run_cli("evaluate-segmentation", "--scenes", "50", "--dataset", inputs / "scene")
    assert code == 1 and "only KITTI folders are scored" in error_line(err)
    code, _, err, _ = run_cli("evaluate-segmentation", "--scenes", "0")
    assert code == 1 and "nothing to evaluate" in error_line(err)


def test_an_output_of_an_unknown_format_is_refused_before_the_first_file_is_written(inputs, run_cli, tmp_path):
    for command in (["segment", inputs / "left.png", "-o", tmp_path / "labels.png", "--overlay", tmp_path / "o.xyz"],
                    ["segment", inputs / "left.png", "-o", tmp_path / "labels.jpg"],
                    ["disparity", inputs / "left.png", inputs / "right.png", "-o", tmp_path / "d.npy", "--picture",
                     tmp_path / "p.xyz"],
                    ["disparity", inputs / "left.png", inputs / "right.png", "-o", tmp_path / "d.tif"]):
        code, _, err, _ = run_cli(*command)
        assert code == 1 and ("extension" in error_line(err) or "written as" in error_line(err)), command
    assert list(tmp_path.iterdir()) == []                     # not the labels or disparity without the rest
