"""The detection output folder: every file present and readable, the HTML report, all or nothing."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import numpy as np
import pytest
from _interrupted_moves import move_stopped_at
from _obstacle_scene import RIG, detection

from stereo_obstacles import __version__, report
from stereo_obstacles.depth import points_from_depth
from stereo_obstacles.errors import InvalidInputError, OutputError
from stereo_obstacles.fileio import read_depth, read_image, read_labels, read_pfm
from stereo_obstacles.obstacle_json import read_obstacles_json
from stereo_obstacles.obstacles import ObstacleList
from stereo_obstacles.point_cloud import read_ply

DETECTION = detection()
TIMINGS = {"segmentation": 0.012, "matching": 0.05, "obstacles": 0.003}
CONFIG = {"tau": 0.6, "corridor_width_m": 1.0}
INPUTS = {"left": "left.png", "right": "right.png"}


def _write(out_dir, calibrated: bool = True):
    return report.write_detection_outputs(
        out_dir, left=DETECTION.left, labels=DETECTION.labels, disparity=DETECTION.disparity,
        depth_m=DETECTION.depth_m if calibrated else None,
        obstacle_list=DETECTION.calibrated if calibrated else DETECTION.uncalibrated,
        calibration=RIG if calibrated else None, config=CONFIG, timings=TIMINGS, inputs=INPUTS)


def test_calibrated_run_writes_every_file_and_each_reads_back(tmp_path):
    out = tmp_path / "out"
    written = _write(out)
    names = sorted(p.name for p in written)
    assert names == sorted(["obstacles.json", "disparity.pfm", "depth.npy", "labels.png", "points.ply", "obstacles.png",
                            "disparity_picture.png", "depth_picture.png", "labels_picture.png", "scan_picture.png",
                            "index.html"])
    assert sorted(p.name for p in out.iterdir()) == names  # nothing else, no staging left-overs
    assert sorted(report.OUTPUT_FILES) == names            # the list the input-overwrite check uses
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    record = read_obstacles_json(out / "obstacles.json")
    assert record.obstacles == DETECTION.calibrated.obstacles and record.calibration == RIG
    assert record.run["timings_s"] == TIMINGS and record.run["config"] == CONFIG and record.run["inputs"] == INPUTS
    np.testing.assert_array_equal(read_pfm(out / "disparity.pfm"), DETECTION.disparity)
    np.testing.assert_array_equal(read_depth(out / "depth.npy"), DETECTION.depth_m)
    np.testing.assert_array_equal(read_labels(out / "labels.png"), DETECTION.labels)
    for picture in ("obstacles.png", "disparity_picture.png", "depth_picture.png", "labels_picture.png"):
        image = read_image(out / picture, mode="color")
        assert image.shape[0] > DETECTION.left.shape[0] and image.shape[2] == 3  # the picture and its legend
    assert read_image(out / "scan_picture.png", mode="color").shape[0] > 400     # the top view and its legend


def test_point_cloud_holds_every_pixel_with_depth_coloured_by_the_left_image(tmp_path):
    _write(tmp_path)
    cloud = read_ply(tmp_path / "points.ply")
    valid = np.isfinite(DETECTION.depth_m)
    assert len(cloud.points) == int(valid.sum())
    np.testing.assert_array_equal(cloud.points, points_from_depth(DETECTION.depth_m, RIG)[valid])
    np.testing.assert_array_equal(cloud.colours, DETECTION.left[valid])


def test_index_html_shows_every_picture_obstacle_rejection_timing_and_the_version(tmp_path):
    written = _write(tmp_path)
    page = (tmp_path / "index.html").read_text(encoding="utf-8")
    sources = set(re.findall(r'<img src="([^"]+)"', page))
    assert sources == {p.name for p in written if p.suffix == ".png" and p.name != "labels.png"}
    links = set(re.findall(r'<a href="([^"]+)"', page))
    assert links == {"obstacles.json", "disparity.pfm", "depth.npy", "labels.png", "points.ply"}
    assert "://" not in page  # self-contained: no external resources
    assert "labels as raw uint8 values (0 unknown, 1 ground, 2 shadow, 3 obstacle)" in page   # no truth-only classes
    rows = re.findall(r"<tr><td[^>]*>(\d+)</td><td>([\d.]+)</td>", page)
    assert rows == [(str(o.id), f"{o.distance_m:.2f}") for o in DETECTION.calibrated.obstacles]  # nearest first
    assert DETECTION.calibrated.rejected[0].reason in page
    assert "free for 4.00 m" in page
    for stage in TIMINGS:
        assert f">{stage}</td><td>{TIMINGS[stage] * 1000:.1f}</td>" in page
    assert ">total</td><td>65.0</td>" in page
    assert "&quot;tau&quot;: 0.6" in page and f"stereo-obstacles {__version__}" in page
    assert "left.png" in page


def test_uncalibrated_run_has_no_depth_files_and_says_pixels(tmp_path):
    written = _write(tmp_path, calibrated=False)
    names = {p.name for p in written}
    assert not names & {"depth.npy", "points.ply", "depth_picture.png", "scan_picture.png"}
    assert {p.name for p in tmp_path.iterdir()} == names
    page = (tmp_path / "index.html").read_text(encoding="utf-8")
    assert "No calibration was given" in page and "distance [m]" not in page
    assert "disparity [px]" in page and "depth_picture.png" not in page
    assert read_obstacles_json(tmp_path / "obstacles.json").calibration is None


def test_a_rerun_removes_the_calibrated_files_it_does_not_write_again(tmp_path):
    _write(tmp_path)
    report.write_detection_outputs(tmp_path, left=DETECTION.left, labels=DETECTION.labels,
                                   disparity=DETECTION.disparity, depth_m=DETECTION.depth_m,
                                   obstacle_list=dataclasses.replace(DETECTION.calibrated, scan=None), calibration=RIG,
                                   config=CONFIG, timings=TIMINGS, inputs=INPUTS)
    names = {p.name for p in tmp_path.iterdir()}
    assert "scan_picture.png" not in names and "depth_picture.png" in names
    assert "scan_picture.png" not in (tmp_path / "index.html").read_text(encoding="utf-8")
    _write(tmp_path, calibrated=False)
    assert not {p.name for p in tmp_path.iterdir()} & set(report.CALIBRATED_ONLY)


def test_failure_midway_leaves_nothing_behind(tmp_path, monkeypatch):
    def broken(*args, **kwargs):
        raise OutputError("disk full")

    monkeypatch.setattr(report, "write_ply", broken)
    with pytest.raises(OutputError, match="disk full"):
        _write(tmp_path / "out")
    assert list(tmp_path.iterdir()) == []


def test_failure_keeps_an_existing_folder_unchanged(tmp_path, monkeypatch):
    out = tmp_path / "out"
    _write(out, calibrated=False)
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    monkeypatch.setattr(report, "labels_picture", lambda labels: 1 / 0)
    with pytest.raises(ZeroDivisionError):
        _write(out)
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_bad_arguments_are_refused_before_anything_is_written(tmp_path):
    with pytest.raises(InvalidInputError, match="depth_m is needed with a calibration"):
        report.write_detection_outputs(tmp_path / "a", left=DETECTION.left, labels=DETECTION.labels,
                                       disparity=DETECTION.disparity, depth_m=None,
                                       obstacle_list=DETECTION.calibrated, calibration=RIG,
                                       config={}, timings={}, inputs={})
    with pytest.raises(InvalidInputError, match=r"labels is \(10, 10\) but the disparity is \(240, 320\)"):
        report.write_detection_outputs(tmp_path / "b", left=DETECTION.left, labels=np.zeros((10, 10), np.uint8),
                                       disparity=DETECTION.disparity, depth_m=None,
                                       obstacle_list=DETECTION.uncalibrated, calibration=None,
                                       config={}, timings={}, inputs={})
    with pytest.raises(InvalidInputError, match="left must be uint8 RGB"):
        report.write_detection_outputs(tmp_path / "c", left=DETECTION.left[..., 0], labels=DETECTION.labels,
                                       disparity=DETECTION.disparity, depth_m=None,
                                       obstacle_list=DETECTION.uncalibrated, calibration=None,
                                       config={}, timings={}, inputs={})
    assert list(tmp_path.iterdir()) == []


def test_terminal_table_nearest_first_with_units():
    text = report.format_obstacle_table(DETECTION.calibrated, True)
    lines = text.splitlines()
    assert "distance [m]" in lines[0] and "disparity [px]" in lines[0]
    assert [line.split()[:2] for line in lines[1:4]] == [["1", "4.00"], ["2", "5.00"], ["3", "8.00"]]
    assert "free for 4.00 m" in text and "flat on the ground" in text


def test_terminal_table_without_calibration_says_values_are_pixels():
    text = report.format_obstacle_table(DETECTION.uncalibrated, False)
    assert text.startswith("No calibration was given") and "pixels" in text.splitlines()[0]
    assert "[m]" not in text and "disparity [px]" in text
    assert [line.split()[:2] for line in text.splitlines()[2:5]] == [["1", "10.5"], ["2", "8.4"], ["3", "5.2"]]


def test_terminal_table_when_nothing_was_found():
    empty = ObstacleList((), np.zeros((4, 4), np.int32))
    assert report.format_obstacle_table(empty, True) == "No obstacles found."


def test_terminal_table_lists_the_largest_rejected_groups_and_sums_up_the_rest():
    from stereo_obstacles.obstacles import RejectedGroup

    rejected = tuple(RejectedGroup((i, 0, i + 4, 4), 100 + i, "flat on the ground plane") for i in range(8))
    text = report.format_obstacle_table(ObstacleList((), np.zeros((4, 4), np.int32), rejected=rejected), True)
    lines = text.splitlines()
    assert [int(line.split()[1]) for line in lines[1:6]] == [107, 106, 105, 104, 103]
    assert lines[6] == "Rejected 3 smaller groups too (303 px; every one with its reason in obstacles.json)"
    assert len(lines) == 7


def test_a_rerun_removes_the_pictures_of_their_former_names_from_its_own_folder_only(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    for name in report.FORMER_PICTURE_NAMES:                              # the user's own files
        (out / name).write_bytes(b"user")
    _write(out, calibrated=False)
    assert all((out / name).read_bytes() == b"user" for name in report.FORMER_PICTURE_NAMES)
    _write(out, calibrated=False)                                         # a rerun over a current report
    assert all((out / name).exists() for name in report.FORMER_PICTURE_NAMES)
    former = tmp_path / "former"                                          # a report of the former kind
    _write(former)
    (former / "disparity_picture.png").rename(former / "disparity.png")
    (former / "depth_picture.png").rename(former / "depth.png")
    _write(former)
    assert not any((former / name).exists() for name in report.FORMER_PICTURE_NAMES)
    assert (former / "disparity_picture.png").exists()


def test_the_library_writer_refuses_a_scene_and_a_users_files_as_the_commands_do(tmp_path):
    # write_detection_outputs replaced a rendered scene's ground truth and a user's index.html (API review)
    from stereo_obstacles.errors import OutputError
    from stereo_obstacles.synthetic import default_scene, render_pair, write_scene_folder

    write_scene_folder(tmp_path / "scene", render_pair(default_scene(160, 120)))
    truth = (tmp_path / "scene" / "obstacles.json").read_bytes()
    with pytest.raises(OutputError, match="holds a rendered scene"):
        _write(tmp_path / "scene")
    assert (tmp_path / "scene" / "obstacles.json").read_bytes() == truth
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "index.html").write_text("my page")
    with pytest.raises(OutputError, match="holds index.html but no report of this tool"):
        _write(tmp_path / "mine")
    assert (tmp_path / "mine" / "index.html").read_text() == "my page"


def _cut_short(out, monkeypatch, calibrated=True):
    """Write a report into ``out`` (which holds one) and stop it where it moves obstacles.json in."""
    with move_stopped_at(monkeypatch, out / "obstacles.json"), pytest.raises(KeyboardInterrupt):
        _write(out, calibrated=calibrated)
    assert not (out / "obstacles.json").exists() and (out / "disparity.pfm").is_file()


def test_a_report_cut_short_while_moving_in_is_replaced_by_the_next_run(tmp_path, monkeypatch):
    # obstacles.json is removed first and moved in last. The staging folder, kept with its record
    # of the move, tells the next run which files there are the report's. batch and video skipped
    # the refusal of foreign files in their own folders instead, and replaced a user's index.html
    # in OUT/<pair> (review, session 24)
    out = tmp_path / "out"
    _write(out)
    (out / "disparity.png").write_text("the user's")                     # a former picture name
    _cut_short(out, monkeypatch)
    kept = [p for p in tmp_path.iterdir() if p.name.startswith(".out.@") and p.name.endswith(".moving")]
    assert len(kept) == 1 and (kept[0] / "obstacles.json").is_file()
    report.check_report_folder(out)
    _write(out)
    assert report.holds_a_report(out) and (out / "disparity.png").read_text() == "the user's"


def test_a_users_file_put_where_a_cut_short_report_was_is_refused(tmp_path, monkeypatch):
    out = tmp_path / "out"
    _write(out)
    _cut_short(out, monkeypatch)
    (out / "labels.png").unlink()
    (out / "labels.png").write_text("mine, written after")                # not the file the move recorded
    with pytest.raises(OutputError, match="holds labels.png but no report of this tool .*nor files a report's move "
                                          "cut short left"):
        _write(out)
    assert (out / "labels.png").read_text() == "mine, written after"


def test_a_run_killed_before_its_move_began_vouches_for_nothing(tmp_path):
    # its staging folder holds obstacles.json (written first) but no record of a move: a folder of
    # that name made later with a user's files in it was replaced, and that folder deleted (review)
    import shutil

    _write(tmp_path / "done")
    shutil.copytree(tmp_path / "done", tmp_path / ".site.@killed00.partial")
    (tmp_path / "site").mkdir()
    (tmp_path / "site" / "index.html").write_text("<h1>mine</h1>")
    with pytest.raises(OutputError, match="holds index.html but no report of this tool"):
        _write(tmp_path / "site")
    assert (tmp_path / "site" / "index.html").read_text() == "<h1>mine</h1>"


def test_the_mark_of_a_cut_short_move_is_found_however_the_folder_is_named(tmp_path, monkeypatch):
    # --out . inside the folder put the staging folder inside it, where --out R did not look (review)
    from stereo_obstacles.atomic import moved_in_files

    real = tmp_path / "real"
    _write(real)
    (tmp_path / "link").symlink_to(real)
    monkeypatch.chdir(real)
    _cut_short(real, monkeypatch)
    assert not any(p.name.startswith(".") for p in real.iterdir())
    for spelled in (Path("."), real, tmp_path / "link", Path("..") / "real"):
        assert "disparity.pfm" in moved_in_files(spelled), spelled
    report.check_report_folder(Path("."))


def test_the_record_of_a_cut_short_move_outlives_writes_that_do_not_replace_its_files(tmp_path, monkeypatch):
    # it was lost to the next write's clean-up of staging folders a minute old, even when that
    # write stopped before its move, or wrote other files (rectify into the same folder): the
    # half-moved report was then refused for good (review)
    import os
    import time

    from stereo_obstacles.atomic import staged_directory

    out = tmp_path / "out"
    _write(out)
    _cut_short(out, monkeypatch)
    for kept in tmp_path.glob(".out.@*"):
        os.utime(kept, (time.time() - 600, time.time() - 600))
    monkeypatch.setattr(report, "write_pfm", lambda *a: (_ for _ in ()).throw(KeyboardInterrupt()))
    with pytest.raises(KeyboardInterrupt):                                # stopped while writing
        _write(out)
    monkeypatch.undo()
    with staged_directory(out) as stage:                                  # another writer's files
        (stage / "notes.txt").write_text("other")
    _write(out)
    assert report.holds_a_report(out) and (out / "notes.txt").is_file()
    assert not list(tmp_path.glob(".out.@*"))                             # spent once replaced


def test_a_folder_a_file_beside_it_cannot_be_renamed_into_gets_its_staging_folder_inside(tmp_path, monkeypatch):
    # --out . at a mount point, or a bind mount of the same file system, put the staging folder
    # beside it: "cannot write to .: Invalid cross-device link" after the earlier report's
    # obstacles.json was removed (reviews)
    import errno
    import os

    from stereo_obstacles import atomic

    out = tmp_path / "out"
    _write(out)
    real_rename = os.rename

    def across_mounts(src, dst):
        if os.path.dirname(os.fspath(src)) == os.fspath(tmp_path) and os.fspath(dst).startswith(os.fspath(out)):
            raise OSError(errno.EXDEV, "Invalid cross-device link")
        real_rename(src, dst)

    monkeypatch.setattr(os, "rename", across_mounts)
    assert atomic._staging_place(out) == out / atomic.INSIDE
    _cut_short(out, monkeypatch)
    monkeypatch.setattr(os, "rename", across_mounts)
    assert [p.name.endswith(".moving") for p in out.iterdir() if p.name.startswith(".")] == [True]
    _write(out)
    assert report.holds_a_report(out) and not [p for p in out.iterdir() if p.name.startswith(".")]
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]            # no probe left behind


def test_a_cut_short_scene_vouches_for_no_report_into_its_folder(tmp_path, monkeypatch):
    # a detect report replaced the ground truth of a scene whose move was cut short: the record
    # did not say what it was the record of (review)
    from stereo_obstacles.synthetic import default_scene, render_pair, write_scene_folder

    pair = render_pair(default_scene(160, 120))
    scene = tmp_path / "scene"
    write_scene_folder(scene, pair)
    with move_stopped_at(monkeypatch, scene / "obstacles.json"), pytest.raises(KeyboardInterrupt):
        write_scene_folder(scene, pair)
    truth = (scene / "disparity.pfm").read_bytes()
    with pytest.raises(OutputError, match="holds disparity.pfm, labels.png"):
        _write(scene)
    assert (scene / "disparity.pfm").read_bytes() == truth
    from stereo_obstacles.datasets import load_pair
    from stereo_obstacles.errors import InputFileError
    with pytest.raises(InputFileError, match="the writing of its files was cut short"):
        load_pair(scene)                                                  # no half-written ground truth read
    write_scene_folder(scene, pair)                                       # the scene writer takes them
    assert load_pair(scene).layout == "synthetic"


def test_spent_records_go_when_the_folder_is_written_anew(tmp_path, monkeypatch):
    import shutil

    out = tmp_path / "out"
    _write(out)
    _cut_short(out, monkeypatch)
    shutil.rmtree(out)
    _write(out)
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_looking_for_records_writes_nothing_and_a_probe_a_kill_left_goes_with_the_next_write(tmp_path):
    # the rename probe ran on every look, writing into the output folder's parent, and one left by
    # a kill stayed for good (review)
    import os
    import time

    from stereo_obstacles.atomic import moved_in_files

    out = tmp_path / "out"
    _write(out)
    before = sorted(p.name for p in tmp_path.iterdir()), sorted(p.name for p in out.iterdir())
    moved_in_files(out)
    report.check_report_folder(out)
    assert (sorted(p.name for p in tmp_path.iterdir()), sorted(p.name for p in out.iterdir())) == before
    left = tmp_path / ".out.@deadbeef.probe"
    left.write_bytes(b"")
    os.utime(left, (time.time() - 120, time.time() - 120))
    _write(out)
    assert not left.exists()


def test_an_uncalibrated_run_after_a_cut_short_calibrated_one_removes_its_depth_files(tmp_path, monkeypatch):
    out = tmp_path / "out"
    _write(out, calibrated=False)
    _cut_short(out, monkeypatch, calibrated=True)
    assert (out / "depth.npy").is_file()
    _write(out, calibrated=False)
    assert not any((out / name).exists() for name in report.CALIBRATED_ONLY)


def test_another_tools_obstacles_json_is_not_written_over(tmp_path):
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "obstacles.json").write_text('{"mine": 1}')
    with pytest.raises(OutputError, match="not a report of this tool"):
        report.check_report_folder(tmp_path / "mine")


def test_a_report_is_not_written_over_a_scene_or_another_tools_obstacles_json(tmp_path):
    from stereo_obstacles.synthetic import default_scene, render_pair, write_scene_folder

    write_scene_folder(tmp_path / "scene", render_pair(default_scene(64, 48)))
    with pytest.raises(OutputError, match="holds a rendered scene"):
        report.check_report_folder(tmp_path / "scene")
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    (foreign / "obstacles.json").write_text('{"mine": 1}')
    with pytest.raises(OutputError, match="not a report of this tool"):
        report.check_report_folder(foreign)
    (foreign / "depth.npy").write_bytes(b"user")
    with pytest.raises(OutputError, match="not a report of this tool"):
        _write(foreign, calibrated=False)                   # the library writer refuses as the commands do
    assert (foreign / "depth.npy").read_bytes() == b"user" and (foreign / "obstacles.json").read_text() == '{"mine": 1}'
    _write(tmp_path / "ours")
    report.check_report_folder(tmp_path / "ours")           # a report of this tool: a rerun is fine
    _write(tmp_path / "ours", calibrated=False)
    users = tmp_path / "users"                              # no obstacles.json, but the names a report writes
    users.mkdir()
    (users / "index.html").write_text("my page")
    (users / "points.ply").write_text("my cloud")
    (users / "notes.txt").write_text("mine")
    with pytest.raises(OutputError, match=r"holds index\.html, points\.ply but no report of this tool"):
        report.check_report_folder(users)
    (users / "index.html").unlink()
    (users / "points.ply").unlink()
    report.check_report_folder(users)                       # other names are no reason to refuse
