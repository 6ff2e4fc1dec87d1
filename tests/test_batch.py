"""The batch command: pair discovery, per-pair failures, resume, local processes and a Dask cluster."""

from __future__ import annotations

import json
import shutil

import cv2
import numpy as np
import pytest

from _stream_frames import N_FRAMES, frames
from stereo_obstacles.batch import (DONE_FILE, SUMMARY_FILE, BatchJob, PairSpec, find_pairs, process_pair,
                                    run_batch)
from stereo_obstacles.atomic import MOVE_RECORD
from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.cli import main
from stereo_obstacles.errors import InputFileError, InvalidInputError
from stereo_obstacles.fileio import read_pfm
from stereo_obstacles.pipeline import DetectionConfig, MatchingOptions
from stereo_obstacles.synthetic import write_scene_folder

CONFIG = DetectionConfig(matching=MatchingOptions(max_disparity=40))


def _write_pair(folder, left_name, right_name, index=0):
    pair = frames()[index]
    cv2.imwrite(str(folder / left_name), cv2.cvtColor(pair.left, cv2.COLOR_RGB2BGR))
    cv2.imwrite(str(folder / right_name), cv2.cvtColor(pair.right, cv2.COLOR_RGB2BGR))


@pytest.fixture
def pairs_dir(tmp_path):
    """Three file pairs, the middle one with a corrupt left image."""
    folder = tmp_path / "pairs"
    folder.mkdir()
    _write_pair(folder, "a_left.png", "a_right.png", 0)
    _write_pair(folder, "b_left.png", "b_right.png", 1)
    _write_pair(folder, "c_left.png", "c_right.png", 2)
    (folder / "b_left.png").write_bytes(b"\x89PNG\r\n\x1a\n truncated")
    return folder


def _summary(out):
    return json.loads((out / SUMMARY_FILE).read_text())


def test_find_pairs_understands_the_usual_layouts(tmp_path):
    _write_pair(tmp_path, "0001_left.png", "0001_right.png")
    _write_pair(tmp_path, "scan_L.png", "scan_R.png")
    _write_pair(tmp_path, "Left-07.jpg", "Right-07.jpg")
    (tmp_path / "lonely_left.png").write_bytes(b"x")
    for side in ("left", "right"):
        (tmp_path / side).mkdir()
    _write_pair(tmp_path / "left", "f9.png", "../right/f9.png")
    write_scene_folder(tmp_path / "scene", frames()[0])
    got = {p.name: p for p in find_pairs(tmp_path)}
    assert sorted(got) == ["0001", "07", "f9", "scan", "scene"]
    assert got["scan"].left.endswith("scan_L.png") and got["scan"].right.endswith("scan_R.png")
    assert got["f9"].right.endswith("right/f9.png")
    assert got["scene"].folder.endswith("scene") and got["scene"].left is None


def test_a_sub_folder_without_images_is_left_out_and_one_with_unreadable_images_fails(tmp_path, caplog):
    # the shared data's calibration_examples/ (text files) made `batch` exit 1 as a failed pair
    write_scene_folder(tmp_path / "scene", frames()[0])
    (tmp_path / "notes").mkdir()
    (tmp_path / "notes" / "calib.txt").write_text("cam0=[1 0 0]")
    (tmp_path / "broken").mkdir()
    (tmp_path / "broken" / "im0.png").write_bytes(b"not an image")
    with caplog.at_level("WARNING", logger="stereo_obstacles"):
        names = [p.name for p in find_pairs(tmp_path)]
    assert names == ["broken", "scene"]
    assert "notes holds no images and no known layout: not a pair, left out" in caplog.text


def test_find_pairs_looks_into_sub_folders_of_name_paired_images(tmp_path):
    for sub in ("urban", "teddy"):
        (tmp_path / sub).mkdir()
    _write_pair(tmp_path / "urban", "urban1_left.png", "urban1_right.png")     # several pairs side by side
    _write_pair(tmp_path / "urban", "urban2_left.png", "urban2_right.png")
    _write_pair(tmp_path / "teddy", "teddy_left.ppm", "teddy_right.ppm")      # one pair: a dataset folder
    got = {p.name: p for p in find_pairs(tmp_path)}
    assert sorted(got) == ["teddy", "urban_urban1", "urban_urban2"]
    assert got["urban_urban2"].left.endswith("urban2_left.png") and got["teddy"].folder.endswith("teddy")
    assert main(["batch", str(tmp_path), "--out", str(tmp_path / "out"), "--workers", "1", "--task", "disparity",
                 "--max-disparity", "40"]) == 0                                # every one of them loads


def test_batch_replaces_its_own_summary_not_a_users_file(tmp_path, capsys):
    (tmp_path / "in").mkdir()
    _write_pair(tmp_path / "in", "x_left.png", "x_right.png")
    out = tmp_path / "out"
    out.mkdir()
    (out / "batch_summary.json").write_text("mine\n")
    args = ["batch", str(tmp_path / "in"), "--out", str(out), "--workers", "1", "--task", "disparity",
            "--max-disparity", "40"]
    assert main(args) == 1
    assert "batch_summary.json exists and is not a batch summary of this tool" in capsys.readouterr().err
    assert (out / "batch_summary.json").read_text() == "mine\n" and not (out / "x").exists()
    (out / "batch_summary.json").unlink()
    assert main(args) == 0 and main(args) == 0                     # its own summary is replaced on a rerun
    assert json.loads((out / "batch_summary.json").read_text())["counts"]["skipped"] == 1


def test_find_pairs_errors(tmp_path):
    with pytest.raises(InputFileError, match="does not exist"):
        find_pairs(tmp_path / "missing")
    with pytest.raises(InputFileError, match="no stereo pairs"):
        find_pairs(tmp_path)
    _write_pair(tmp_path, "x_left.png", "x_right.png")
    _write_pair(tmp_path, "x-L.png", "x-R.png")
    with pytest.raises(InputFileError, match="share the output name"):
        find_pairs(tmp_path)
    with pytest.raises(InvalidInputError, match="either a folder or left and right"):
        PairSpec("p", folder="f", left="l", right="r")
    with pytest.raises(InvalidInputError, match="task"):
        BatchJob(PairSpec("p", folder="f"), "out", "segment", CONFIG)
    rig = StereoCalibration(focal_px=700.0, cx_px=319.5, cy_px=239.5, baseline_m=0.12)
    for calib_file, calibration in (("rig.json", None), (None, rig)):
        with pytest.raises(InvalidInputError, match="calib_file and calibration: give both"):
            BatchJob(PairSpec("p", folder="f"), "out", "detect", CONFIG, calib_file, calibration)
    with pytest.raises(InvalidInputError, match="calibration must be a StereoCalibration or CameraPairCalibration .*"
                                                "got str"):
        BatchJob(PairSpec("p", folder="f"), "out", "detect", CONFIG, "rig.yml", "mm")     # the former calib_unit
    assert BatchJob(PairSpec("p", folder="f"), "out", "detect", CONFIG, "rig.json", rig).calibration is rig


def test_corrupt_pair_is_reported_and_the_rest_done_then_resumed(pairs_dir, tmp_path, capsys):
    out = tmp_path / "out"
    args = ["batch", str(pairs_dir), "--out", str(out), "--workers", "1", "--task", "disparity",
            "--max-disparity", "40"]
    assert main(args) == 1
    err = capsys.readouterr().err
    assert "b: failed: InputFileError" in err and "b_left.png" in err
    summary = _summary(out)
    assert summary["counts"] == {"done": 2, "skipped": 0, "failed": 1}
    failed = [p for p in summary["pairs"] if p["status"] == "failed"]
    assert [p["name"] for p in failed] == ["b"] and "not an image" in failed[0]["reason"]
    assert (out / "a" / DONE_FILE).is_file() and not (out / "b").exists()
    disparity = read_pfm(out / "c" / "disparity.pfm")
    assert disparity.shape == frames()[2].disparity.shape
    stamp = (out / "a" / "disparity.pfm").stat().st_mtime_ns

    (out / "c" / DONE_FILE).unlink()                 # as if the first run died before c was complete
    assert main(args) == 1
    summary = _summary(out)
    assert summary["counts"] == {"done": 1, "skipped": 1, "failed": 1}
    assert {p["name"]: p["status"] for p in summary["pairs"]} == {"a": "skipped", "b": "failed", "c": "done"}
    assert (out / "a" / "disparity.pfm").stat().st_mtime_ns == stamp        # not redone

    _write_pair(pairs_dir, "b_left.png", "b_right.png", 1)                   # repaired
    assert main(args) == 0
    assert _summary(out)["counts"] == {"done": 1, "skipped": 2, "failed": 0}


def test_going_on_with_other_settings_in_the_same_out_is_refused(pairs_dir, tmp_path, capsys):
    # the pairs done before used to be skipped as done, their outputs made with the old settings
    # and the summary rewritten with the new ones (found by a review)
    out = tmp_path / "out"
    args = ["batch", str(pairs_dir), "--out", str(out), "--workers", "1", "--task", "disparity", "--max-disparity", "40"]
    assert main(args) == 1                                               # pair b is corrupt
    summary = (out / SUMMARY_FILE).read_text()
    capsys.readouterr()
    assert main(args[:-1] + ["32"]) == 1
    err = capsys.readouterr().err
    assert "2 pair(s) were done with another option matching.max_disparity (" in err and len(err.splitlines()) == 1
    assert "out/a" in err and "out/c" in err and "skipped as done" in err
    assert main(args[:6] + ["--task", "detect", "--max-disparity", "40"]) == 1
    assert "were done with another task (" in capsys.readouterr().err         # not every option of the other task
    assert (out / SUMMARY_FILE).read_text() == summary                   # nothing rewritten
    write_scene_folder(tmp_path / "scene", frames()[0])                 # a rectified rig's calibration
    assert main(args + ["--max-distance", "5", "--matching-scale", "1",      # none used by the disparity task
                        "--calib", str(tmp_path / "scene" / "calibration.json")]) == 1
    assert _summary(out)["counts"] == {"done": 0, "skipped": 2, "failed": 1}
    capsys.readouterr()
    assert main(args + ["--seeds", "sobel"]) == 1                        # the default, written out (review)
    assert "were done with another" not in capsys.readouterr().err
    assert _summary(out)["counts"] == {"done": 0, "skipped": 2, "failed": 1}
    (out / SUMMARY_FILE).unlink()                                        # as if killed: no summary to go by
    assert main(args[:-1] + ["32"]) == 1
    assert "were done with another option matching.max_disparity" in capsys.readouterr().err


def test_a_resume_over_pairs_done_by_a_version_without_an_option_says_so(tmp_path, capsys):
    write_scene_folder(tmp_path / "in" / "scene", frames()[0])
    args = ["batch", str(tmp_path / "in"), "--out", str(tmp_path / "out"), "--workers", "1"]
    assert main(args) == 0
    done = tmp_path / "out" / "scene" / DONE_FILE
    record = json.loads(done.read_text())
    del record["settings"]["options"]["obstacles"]["scan_sector_deg"]     # as an older version wrote it
    done.write_text(json.dumps(record))
    capsys.readouterr()
    assert main(args) == 1
    err = capsys.readouterr().err
    assert "done with another option obstacles.scan_sector_deg (or by a version of this tool without some" in err
    record["settings"]["options"]["obstacles"]["scan_sector_deg"] = 2.0  # a value of its own: no such note
    done.write_text(json.dumps(record))
    assert main(args) == 1 and "or by a version" not in capsys.readouterr().err


def test_the_calibration_is_compared_by_its_values_not_its_file_name(tmp_path, capsys, monkeypatch):
    write_scene_folder(tmp_path / "in" / "scene", frames()[0])
    calibration = json.loads((tmp_path / "in" / "scene" / "calibration.json").read_text())
    for folder, baseline in (("a", calibration["baseline_m"]), ("b", 2 * calibration["baseline_m"])):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "cal.json").write_text(json.dumps({**calibration, "baseline_m": baseline}))
    monkeypatch.chdir(tmp_path / "a")
    args = ["batch", "../in", "--out", "../out", "--workers", "1", "--calib", "cal.json"]
    assert main(args) == 0
    assert main(args[:-1] + ["../a/cal.json"]) == 0                      # the same file named otherwise
    monkeypatch.chdir(tmp_path / "b")                                    # another file of the same name
    capsys.readouterr()
    assert main(args) == 1 and "1 pair(s) were done with another calibration" in capsys.readouterr().err


def test_detect_task_writes_the_detect_outputs_with_the_folder_calibration(tmp_path):
    write_scene_folder(tmp_path / "in" / "scene", frames()[0])
    out = tmp_path / "out"
    assert main(["batch", str(tmp_path / "in"), "--out", str(out), "--workers", "1"]) == 0
    done = json.loads((out / "scene" / DONE_FILE).read_text())
    assert done["task"] == "detect" and done["obstacles"] >= 1 and done["inputs"]["layout"] == "synthetic"
    document = json.loads((out / "scene" / "obstacles.json").read_text())
    assert document["units"] == "metres"
    scene = tmp_path / "in" / "scene"                                    # which files were read, as detect says
    assert {k: document["run"]["inputs"][k] for k in ("left", "right", "calibration", "rectification")} == {
        "left": str(scene / "left.png"), "right": str(scene / "right.png"), "calibration": str(scene / "calibration.json"),
        "rectification": None}
    assert done["nearest_distance_m"] == pytest.approx(frames()[0].obstacles[0].distance_m, rel=0.15)


def test_a_dataset_folder_given_itself_is_one_pair_with_its_own_calibration(tmp_path, shared_dataset):
    # it used to be read as a pair of _left/_right files without its Calib.txt: no distances
    write_scene_folder(tmp_path / "scene", frames()[0])
    assert [(p.name, p.folder) for p in find_pairs(tmp_path / "scene")] == [("scene", str(tmp_path / "scene"))]
    assert main(["batch", str(tmp_path / "scene"), "--out", str(tmp_path / "out"), "--workers", "1"]) == 0
    assert json.loads((tmp_path / "out" / "scene" / "obstacles.json").read_text())["units"] == "metres"
    kitti = shared_dataset("kitti2015_000005")
    assert [(p.name, p.folder) for p in find_pairs(kitti)] == [("kitti2015_000005", str(kitti))]
    # a layout without calibration given itself was "no stereo pairs found" (review, session 24)
    for name in ("opencv_aloe", "middlebury2003_teddy"):
        folder = shared_dataset(name)
        assert [(p.name, p.folder) for p in find_pairs(folder)] == [(name, str(folder))]
    assert main(["batch", str(shared_dataset("opencv_aloe")), "--out", str(tmp_path / "aloe"), "--workers", "1",
                 "--task", "disparity"]) == 0
    assert (tmp_path / "aloe" / "opencv_aloe" / "disparity.pfm").is_file()


def test_calib_replaces_a_dataset_folders_own_calibration_that_does_not_parse(tmp_path, capsys):
    # the folder's calib.txt was read before --calib replaced it, and failed the pair
    folder = tmp_path / "in" / "rig"
    folder.mkdir(parents=True)
    _write_pair(folder, "im0.png", "im1.png")
    (folder / "calib.txt").write_text("cam0=[garbage\n")
    write_scene_folder(tmp_path / "scene", frames()[0])
    calib = str(tmp_path / "scene" / "calibration.json")
    for given, name in ((tmp_path / "in", "rig"), (folder, "rig")):   # a folder of datasets, or the dataset itself
        out = tmp_path / f"out_{given.name}"
        assert main(["batch", str(given), "--out", str(out), "--workers", "1", "--calib", calib]) == 0
        document = json.loads((out / name / "obstacles.json").read_text())
        assert document["units"] == "metres" and document["run"]["inputs"]["calibration"] == calib
        capsys.readouterr()
        # without --calib the pair fails with the file's fault (the dataset itself was "no stereo pairs found")
        assert main(["batch", str(given), "--out", str(tmp_path / f"plain_{given.name}"), "--workers", "1"]) == 1
        assert "rig: failed: CalibrationError: " in capsys.readouterr().err


def test_a_rerun_replaces_a_pair_killed_while_its_report_moved_in(tmp_path):
    # the library writer's folder check refused batch's own half-moved report (review, session 23)
    write_scene_folder(tmp_path / "in" / "scene", frames()[0])
    out = tmp_path / "out"
    args = ["batch", str(tmp_path / "in"), "--out", str(out), "--workers", "1"]
    assert main(args) == 0
    stage = out / ".scene.@killed00.moving"                         # as a SIGKILL while moving in leaves it:
    stage.mkdir()                                                   # its record of the move, the last files
    record = [[p.name, [st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns]]
              for p in (out / "scene").iterdir() if (st := p.lstat()) and p.name != DONE_FILE]
    (stage / MOVE_RECORD).write_text(json.dumps({"kind": "report", "files": record}))
    for name in ("obstacles.json", "index.html"):
        (out / "scene" / name).rename(stage / name)
    (out / "scene" / DONE_FILE).unlink()
    assert main(args) == 0 and _summary(out)["counts"]["done"] == 1
    assert (out / "scene" / "obstacles.json").is_file()
    # without that mark the files are a user's: the pair fails and they stay (review, session 24)
    (tmp_path / "out2" / "scene").mkdir(parents=True)
    (tmp_path / "out2" / "scene" / "index.html").write_text("my page")
    assert main(["batch", str(tmp_path / "in"), "--out", str(tmp_path / "out2"), "--workers", "1"]) == 1
    assert (tmp_path / "out2" / "scene" / "index.html").read_text() == "my page"
    # but a rendered scene there is still not written over: batch over its own input (review)
    truth = (tmp_path / "in" / "scene" / "obstacles.json").read_bytes()
    assert main(["batch", str(tmp_path / "in" / "scene"), "--out", str(tmp_path / "in"), "--workers", "1"]) == 1
    assert (tmp_path / "in" / "scene" / "obstacles.json").read_bytes() == truth


def test_a_dataset_folder_named_dot_or_beside_sub_folders_keeps_its_name_and_them(tmp_path, monkeypatch):
    write_scene_folder(tmp_path / "scene", frames()[0])
    write_scene_folder(tmp_path / "scene" / "more", frames()[1])
    monkeypatch.chdir(tmp_path / "scene")
    # named "", its outputs went into --out itself (found by a review); its sub-folders were dropped
    assert sorted((p.name, p.folder) for p in find_pairs(".")) == [("more", "more"), ("scene", ".")]


def _halved_kitti(folder, shared_dataset):
    """``folder`` holding KITTI frame 000005 at 621x188 with its Calib.txt (for 1242x375)."""
    kitti = shared_dataset("kitti2015_000005")
    folder.mkdir()
    shutil.copy(kitti / "Calib.txt", folder / "Calib.txt")
    for side in ("left", "right"):
        image = cv2.imread(str(kitti / f"000005_10_{side}.png"))
        cv2.imwrite(str(folder / f"000005_10_{side}.png"), cv2.resize(image, (621, 188), interpolation=cv2.INTER_AREA))
    return folder


def test_a_dataset_calibration_for_other_images_is_warned_of_in_batch(tmp_path, shared_dataset, caplog):
    _halved_kitti(tmp_path / "half", shared_dataset)
    with caplog.at_level("WARNING", logger="stereo_obstacles"):
        found = find_pairs(tmp_path / "half")
    assert "far from the centre" not in caplog.text          # said once, when the pair is run (it came twice)
    outcome = process_pair(BatchJob(found[0], str(tmp_path / "out"), "detect", CONFIG))
    assert outcome.status == "done"
    assert sum("lies far from the centre of the 621x188 images" in w for w in outcome.warnings) == 1


def test_a_report_inside_the_input_folder_is_not_a_pair_and_probing_says_nothing(tmp_path, caplog):
    # a detect report beside a dataset's files was a failed pair (found by a review)
    write_scene_folder(tmp_path / "scene", frames()[0])
    assert main(["detect", str(tmp_path / "scene" / "left.png"), str(tmp_path / "scene" / "right.png"), "--calib",
                 str(tmp_path / "scene" / "calibration.json"), "--out", str(tmp_path / "scene" / "report")]) == 0
    caplog.clear()
    with caplog.at_level("INFO", logger="stereo_obstacles"):
        assert [p.name for p in find_pairs(tmp_path / "scene")] == ["scene"]
    assert "report holds a report of this tool and no pair: left out" in caplog.text
    # a folder of pairs that holds a report too still gives its pairs (it was dropped; review)
    write_scene_folder(tmp_path / "in" / "s1", frames()[1])
    (tmp_path / "in" / "pairs").mkdir()
    _write_pair(tmp_path / "in" / "pairs", "a_left.png", "a_right.png")
    _write_pair(tmp_path / "in" / "pairs", "b_left.png", "b_right.png")
    assert main(["detect", str(tmp_path / "in" / "pairs" / "a_left.png"), str(tmp_path / "in" / "pairs" / "a_right.png"),
                 "--out", str(tmp_path / "in" / "pairs")]) == 0
    assert sorted(p.name for p in find_pairs(tmp_path / "in")) == ["pairs_a", "pairs_b", "s1"]


def test_probing_a_folder_for_a_dataset_says_nothing(tmp_path, shared_dataset, caplog):
    # the off-centre warning of a probed dataset came twice: when found and when run (review)
    _halved_kitti(tmp_path / "half", shared_dataset)
    from stereo_obstacles import batch

    with caplog.at_level("WARNING", logger="stereo_obstacles"):
        assert batch._is_a_dataset(tmp_path / "half")
    assert "far from the centre" not in caplog.text


def test_two_local_worker_processes(pairs_dir, tmp_path):
    _write_pair(pairs_dir, "b_left.png", "b_right.png", 1)
    jobs = [BatchJob(p, str(tmp_path / "out" / p.name), "disparity", CONFIG) for p in find_pairs(pairs_dir)]
    outcomes = run_batch(jobs, workers=2)
    assert sorted((o.name, o.status) for o in outcomes) == [("a", "done"), ("b", "done"), ("c", "done")]
    assert all((tmp_path / "out" / n / DONE_FILE).is_file() for n in "abc")


def test_dask_local_cluster(pairs_dir, tmp_path):
    distributed = pytest.importorskip("distributed")
    jobs = [BatchJob(p, str(tmp_path / "out" / p.name), "disparity", CONFIG) for p in find_pairs(pairs_dir)]
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=None) as cluster:
        outcomes = run_batch(jobs, scheduler=cluster.scheduler_address)
    assert sorted((o.name, o.status) for o in outcomes) == [("a", "done"), ("b", "failed"), ("c", "done")]
    assert (tmp_path / "out" / "a" / DONE_FILE).is_file()


def test_should_stop_ends_the_batch_after_the_current_pair(pairs_dir, tmp_path):
    jobs = [BatchJob(p, str(tmp_path / "out" / p.name), "disparity", CONFIG) for p in find_pairs(pairs_dir)]
    outcomes = run_batch(jobs, should_stop=lambda: True)
    assert [o.name for o in outcomes] == ["a"]
    assert not (tmp_path / "out" / "c").exists()


def test_stopped_worker_processes_report_every_pair_they_finished(tmp_path):
    folder = tmp_path / "pairs"
    folder.mkdir()
    for k in range(8):
        _write_pair(folder, f"p{k}_left.png", f"p{k}_right.png", k % N_FRAMES)
    jobs = [BatchJob(p, str(tmp_path / "out" / p.name), "disparity", CONFIG) for p in find_pairs(folder)]
    outcomes = run_batch(jobs, workers=2, should_stop=lambda: True)       # stop at the first finished pair
    done = sorted(p.parent.name for p in (tmp_path / "out").glob(f"*/{DONE_FILE}"))
    assert 1 <= len(done) < len(jobs)                   # the pairs already started finished, no new one began
    assert sorted(o.name for o in outcomes) == done      # and each of them is reported (3-5 were not)


def test_process_pair_never_raises(tmp_path):
    job = BatchJob(PairSpec("ghost", folder=str(tmp_path / "nowhere")), str(tmp_path / "out"), "detect", CONFIG)
    outcome = process_pair(job)
    assert outcome.status == "failed" and "nowhere" in outcome.reason
    shutil.rmtree(tmp_path / "out", ignore_errors=True)


def test_warnings_name_their_pair(tmp_path, caplog):
    folder = tmp_path / "pairs"
    folder.mkdir()
    _write_pair(folder, "good_left.png", "good_right.png", 0)
    same = cv2.cvtColor(frames()[1].left, cv2.COLOR_RGB2BGR)      # identical images: a warning, no failure
    cv2.imwrite(str(folder / "same_left.png"), same)
    cv2.imwrite(str(folder / "same_right.png"), same)
    out = tmp_path / "out"
    assert main(["batch", str(folder), "--out", str(out), "--workers", "1", "--task", "disparity",
                 "--max-disparity", "40"]) == 0
    named = [r.getMessage() for r in caplog.records if r.name == "stereo_obstacles.batch" and r.levelname == "WARNING"]
    assert named and all(message.startswith("same: ") for message in named)
    assert json.loads((out / "same" / DONE_FILE).read_text())["warnings"]
    assert json.loads((out / "good" / DONE_FILE).read_text())["warnings"] == []


def test_an_output_folder_that_is_the_input_folder_is_refused_and_one_inside_it_is_skipped(pairs_dir, tmp_path,
                                                                                            capsys):
    write_scene_folder(tmp_path / "in" / "scene", frames()[0])
    labels = (tmp_path / "in" / "scene" / "labels.png").read_bytes()
    assert main(["batch", str(tmp_path / "in"), "--out", str(tmp_path / "in")]) == 1     # would replace labels.png
    assert "is the input folder" in capsys.readouterr().err
    assert (tmp_path / "in" / "scene" / "labels.png").read_bytes() == labels
    args = ["batch", str(tmp_path / "in"), "--out", str(tmp_path / "in" / "results"), "--task", "disparity",
            "--workers", "1", "--max-disparity", "40"]
    assert main(args) == 0
    assert main(args) == 0                                    # the results folder is not taken for a pair
    assert _summary(tmp_path / "in" / "results")["counts"] == {"done": 0, "skipped": 1, "failed": 0}


def test_sigterm_ends_a_batch_with_143_and_a_summary_of_every_finished_pair(tmp_path):
    import signal
    import subprocess
    import sys
    import time

    folder = tmp_path / "pairs"
    folder.mkdir()
    for k in range(24):
        _write_pair(folder, f"p{k:02d}_left.png", f"p{k:02d}_right.png", k % N_FRAMES)
    out = tmp_path / "out"
    process = subprocess.Popen([sys.executable, "-m", "stereo_obstacles", "batch", str(folder), "--out", str(out),
                                "--workers", "2"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and process.poll() is None and not list(out.glob(f"*/{DONE_FILE}")):
        time.sleep(0.05)
    process.send_signal(signal.SIGTERM)
    _, err = process.communicate(timeout=120)
    assert process.returncode == 143, err
    summary = _summary(out)
    written = len(list(out.glob(f"*/{DONE_FILE}")))
    assert summary["interrupted"] is True and summary["counts"]["done"] == written < 24


def test_finished_unreported_reads_back_the_done_files_of_the_pending_pairs(tmp_path):
    import json

    from stereo_obstacles.batch import PairOutcome, finished_unreported

    jobs = {name: BatchJob(PairSpec(name, folder="in"), str(tmp_path / name), "disparity", CONFIG)
            for name in ("reported", "finished", "torn", "listed", "running")}
    for name in ("reported", "finished"):
        (tmp_path / name).mkdir()
        (tmp_path / name / DONE_FILE).write_text(json.dumps({"name": name, "task": "disparity", "seconds": 0.5,
                                                             "density": 0.7, "warnings": ["w"]}))
    for name, text in (("torn", '{"name": "to'), ("listed", "[1, 2]")):
        (tmp_path / name).mkdir()
        (tmp_path / name / DONE_FILE).write_text(text)
    found = finished_unreported(jobs.values(), [PairOutcome("reported", "done", 0.1)])
    assert [(o.name, o.status, o.seconds, o.details, o.warnings) for o in found] == [
        ("finished", "done", 0.5, {"density": 0.7}, ("w",))]


@pytest.mark.parametrize("out", ["res/run1", "grp/results", "res/run2/"])
def test_an_output_folder_deep_in_the_input_counts_the_folders_on_its_way_for_their_pairs_only(tmp_path, out):
    (tmp_path / "in" / "grp").mkdir(parents=True)
    _write_pair(tmp_path / "in" / "grp", "a_left.png", "a_right.png")
    _write_pair(tmp_path / "in" / "grp", "b_left.png", "b_right.png")
    if out.startswith("res"):
        (tmp_path / "in" / "res" / "run1").mkdir(parents=True)          # an earlier run's results
        (tmp_path / "in" / "res" / "Thumbs.db").write_text("x")
    # res/ holds results: not a pair; grp/ holds pairs beside the output: kept
    assert sorted(p.name for p in find_pairs(tmp_path / "in", skip=tmp_path / "in" / out)) == ["grp_a", "grp_b"]


def test_a_grey_and_a_colour_image_make_a_pair_for_the_disparity_task(tmp_path):
    folder = tmp_path / "in"
    folder.mkdir()
    _write_pair(folder, "p_left.png", "p_right.png")
    grey = cv2.cvtColor(cv2.imread(str(folder / "p_left.png")), cv2.COLOR_BGR2GRAY)
    cv2.imwrite(str(folder / "p_left.png"), grey)
    assert main(["batch", str(folder), "--out", str(tmp_path / "out"), "--task", "disparity", "--workers", "1",
                 "--max-disparity", "40"]) == 0
    assert (tmp_path / "out" / "p" / DONE_FILE).is_file()


def test_pair_names_differing_only_in_case_are_refused(tmp_path):
    _write_pair(tmp_path, "Teddy_left.png", "Teddy_right.png")
    _write_pair(tmp_path, "teddy_left.png", "teddy_right.png")
    with pytest.raises(InputFileError, match="share the output name"):
        find_pairs(tmp_path)


def test_a_pair_too_narrow_for_the_default_disparity_range_is_warned_about_as_such(tmp_path, caplog):
    from stereo_obstacles.synthetic import default_scene, render_pair

    pair = render_pair(default_scene(320, 240))                            # its nearest box at about 10 px
    for side, image in (("left", pair.left), ("right", pair.right)):       # 30 px wide: the default range is 10 px
        cv2.imwrite(str(tmp_path / f"n_{side}.png"), cv2.cvtColor(np.ascontiguousarray(image[:, 30:60]),
                                                                  cv2.COLOR_RGB2BGR))
    with caplog.at_level("WARNING"):
        assert main(["batch", str(tmp_path), "--out", str(tmp_path / "out"), "--workers", "1",
                     "--task", "disparity"]) == 0
    assert "largest disparity searched, 10 px" in caplog.text and "the default limit is a third" in caplog.text
