"""The ``stereo-obstacles scene`` command: the files it writes and how it fails."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

from _interrupted_moves import move_stopped_at
from stereo_obstacles.calibration import read_calibration_json
from stereo_obstacles.cli import main
from stereo_obstacles.fileio import read_depth, read_disparity, read_image, read_labels
from stereo_obstacles.labels import Label
from stereo_obstacles.synthetic import default_scene, render_pair
from stereo_obstacles.synthetic.scene_files import SCENE_FILES


def test_scene_command_writes_every_file_and_says_where(tmp_path, capsys):
    out = tmp_path / "scene"
    assert main(["scene", "--out", str(out), "--size", "96x72"]) == 0
    assert str(out) in capsys.readouterr().out
    assert sorted(p.name for p in out.iterdir()) == sorted(set(SCENE_FILES) - {"camera_pair.json"})   # rectified
    expected = render_pair(default_scene(96, 72))
    np.testing.assert_array_equal(read_image(out / "left.png", mode="color"), expected.left)
    np.testing.assert_array_equal(read_image(out / "right.png", mode="color"), expected.right)
    np.testing.assert_array_equal(read_disparity(out / "disparity.pfm"), expected.disparity)
    np.testing.assert_array_equal(read_depth(out / "depth.npy"), expected.depth)
    np.testing.assert_array_equal(read_labels(out / "labels.png"), expected.labels)
    np.testing.assert_array_equal(read_labels(out / "instances.png"), expected.instances)
    np.testing.assert_array_equal(read_labels(out / "nonocc.png") == 255, expected.nonocc)
    np.testing.assert_array_equal(read_labels(out / "shadow.png") == 255, expected.cast_shadow)
    assert read_calibration_json(out / "calibration.json") == expected.calibration
    obstacles = json.loads((out / "obstacles.json").read_text())
    assert [o["obstacle_id"] for o in obstacles["obstacles"]] == [o.obstacle_id for o in expected.obstacles]
    scene = json.loads((out / "scene.json").read_text())
    assert scene["seed"] == 0 and scene["labels"]["SHADOW"] == int(Label.SHADOW)
    assert scene["right_camera"]["rectified"] is True
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_scene_command_options_reach_the_renderer(tmp_path):
    out = tmp_path / "s"
    assert main(["scene", "--out", str(out), "--size", "80x60", "--seed", "4", "--ground", "grass",
                 "--noise", "2", "--gain-diff", "0.1", "--right-rotation-deg", "0.5", "0", "0",
                 "--right-offset-px", "1.5", "--no-shadows", "--jpeg-quality", "60"]) == 0
    scene = json.loads((out / "scene.json").read_text())
    assert scene["render_options"]["jpeg_quality"] == 60
    assert scene["seed"] == 4 and scene["scene"]["ground"]["name"] == "grass"
    assert scene["render_options"]["right_gain"] == pytest.approx(1.1)
    assert scene["right_camera"]["vertical_offset_px"] == 1.5 and scene["right_camera"]["rectified"] is False
    assert not np.any(read_labels(out / "labels.png") == Label.SHADOW)


def test_scene_command_writes_a_sequence(tmp_path):
    out = tmp_path / "seq"
    assert main(["scene", "--out", str(out), "--size", "48x36", "--frames", "2", "--speed", "0.25"]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["frame_0000", "frame_0001"]
    second = json.loads((out / "frame_0001" / "obstacles.json").read_text())
    assert second["forward_m"] == 0.25


def test_a_sequence_replaces_a_single_scene_and_loads_back_frame_by_frame(tmp_path, capsys):
    from stereo_obstacles.datasets import list_frames, load_pair

    out = tmp_path / "walk"
    assert main(["scene", "--out", str(out), "--size", "64x48", "--seed", "7"]) == 0
    assert main(["scene", "--out", str(out), "--size", "64x48", "--seed", "5", "--frames", "2"]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["frame_0000", "frame_0001"]    # no stale seed-7 files
    assert list_frames(out) == ("frame_0000", "frame_0001")
    assert all(load_pair(out, frame=frame).layout == "synthetic" for frame in ("frame_0000", "frame_0001"))
    assert main(["scene", "--out", str(tmp_path / "one"), "--size", "64x48", "--speed", "0.1"]) == 1
    assert "give --frames N" in capsys.readouterr().err
    assert main(["scene", "--out", str(out), "--size", "64x48", "--frames", "3"]) == 0
    capsys.readouterr()
    assert main(["scene", "--out", str(out), "--size", "64x48", "--frames", "2"]) == 0
    assert list_frames(out) == ("frame_0000", "frame_0001")                 # not the longer walk's third
    assert f"removed 1 frame of an earlier sequence from {out} (frame_0002)" in capsys.readouterr().err
    assert main(["scene", "--out", str(out), "--size", "64x48"]) == 0
    assert list_frames(out) == (None,) and load_pair(out).layout == "synthetic"   # one scene, no stale frames
    assert f"removed 2 frames of an earlier sequence from {out} (frame_0000..frame_0001)" in capsys.readouterr().err


@pytest.mark.parametrize("size", ["640", "0x480", "axb", "20000x10"])
def test_bad_size_fails_with_one_line_and_writes_nothing(tmp_path, capsys, size):
    out = tmp_path / "scene"
    assert main(["scene", "--out", str(out), "--size", size]) == 1
    err = capsys.readouterr().err.strip()
    assert "--size" in err and "\n" not in err
    assert list(tmp_path.iterdir()) == []


def test_unwritable_output_fails_with_one_line_and_leaves_nothing(tmp_path, capsys):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    assert main(["scene", "--out", str(blocker / "scene"), "--size", "48x36"]) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith("stereo-obstacles: error:") and "\n" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a_file"]


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="needs a non-root POSIX user")
def test_read_only_parent_fails_cleanly(tmp_path, capsys):
    parent = tmp_path / "ro"
    parent.mkdir()
    parent.chmod(0o500)
    try:
        assert main(["scene", "--out", str(parent / "scene"), "--size", "48x36"]) == 1
        assert "\n" not in capsys.readouterr().err.strip()
        assert list(parent.iterdir()) == []
    finally:
        parent.chmod(0o700)


def test_bad_jpeg_quality_is_refused_by_the_scene_command(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["scene", "--out", str(tmp_path / "s"), "--jpeg-quality", "0"])
    assert exit_info.value.code == 2
    assert "expected a JPEG quality 1..100" in capsys.readouterr().err
    assert not (tmp_path / "s").exists()


@pytest.mark.parametrize("gain", ["-1", "-0.9", "3.5", "inf", "nan"])
def test_a_right_gain_out_of_range_is_refused_by_the_option_name(tmp_path, capsys, gain):
    assert main(["scene", "--out", str(tmp_path / "s"), "--size", "48x36", "--gain-diff", gain]) == 1
    assert "--gain-diff must be in [-0.75, 3]" in capsys.readouterr().err and not (tmp_path / "s").exists()


def test_frames_of_an_earlier_sequence_go_but_nothing_of_the_users(tmp_path):
    import json

    out = tmp_path / "walk"
    assert main(["scene", "--out", str(out), "--size", "48x36", "--frames", "3"]) == 0
    (out / "frame_0002" / "my_results").mkdir()
    (out / "frame_0002" / "my_results" / "notes.txt").write_text("mine")
    (out / "frame_0009").mkdir()                                           # someone else's frame
    (out / "frame_0009" / "scene.json").write_text(json.dumps({"format": "blender-export"}))
    (out / "frame_0010").symlink_to(out / "frame_0000")
    assert main(["scene", "--out", str(out), "--size", "48x36", "--frames", "2"]) == 0
    assert (out / "frame_0002" / "my_results" / "notes.txt").read_text() == "mine"
    assert not (out / "frame_0002" / "scene.json").exists() and not (out / "frame_0002" / "left.png").exists()
    assert (out / "frame_0009" / "scene.json").exists() and (out / "frame_0010").is_symlink()


def test_a_sequence_into_a_folder_of_the_users_own_files_keeps_them(tmp_path):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "left.png").write_bytes(b"my picture")
    (out / "obstacles.json").write_text("{}")
    assert main(["scene", "--out", str(out), "--size", "48x36", "--frames", "2"]) == 0
    assert (out / "left.png").read_bytes() == b"my picture" and (out / "obstacles.json").read_text() == "{}"


def test_frame_folders_that_are_not_this_commands_are_refused_before_rendering(tmp_path, capsys):
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    out = tmp_path / "walk"
    out.mkdir()
    (out / "frame_0001").symlink_to(elsewhere)                              # writing through it would land there
    assert main(["scene", "--out", str(out), "--size", "48x36", "--frames", "2"]) == 1
    assert "is not a frame this command wrote" in capsys.readouterr().err and list(elsewhere.iterdir()) == []
    (out / "frame_0001").unlink()
    (out / "frame_0001").write_text("a file")
    assert main(["scene", "--out", str(out), "--size", "48x36", "--frames", "2"]) == 1
    assert "is not a frame this command wrote" in capsys.readouterr().err
    (out / "frame_0001").unlink()
    (out / "frame_0001").mkdir()
    (out / "frame_0001" / "data.csv").write_text("another tool's")      # a folder of other files
    assert main(["scene", "--out", str(out), "--size", "48x36", "--frames", "2"]) == 1
    assert "is not a frame this command wrote" in capsys.readouterr().err
    (out / "frame_0001" / "left.png").write_text("mine")                 # and one with a file of a scene's names
    assert main(["scene", "--out", str(out), "--size", "48x36", "--frames", "2"]) == 1
    assert "frame_0001 holds left.png but is not a frame this command wrote" in capsys.readouterr().err
    assert (out / "frame_0001" / "left.png").read_text() == "mine"


def test_a_sequence_cut_short_while_moving_in_leaves_no_frame_passing_for_a_whole_scene(tmp_path, monkeypatch):
    # frame_0001 held seed 4's depth, disparity and labels beside seed 3's images and scene.json,
    # and passed for a scene: wrong ground truth without a word (review, session 24)
    from stereo_obstacles.synthetic.scene_files import holds_a_scene

    out = tmp_path / "walk"
    assert main(["scene", "--out", str(out), "--size", "48x36", "--seed", "3", "--frames", "2"]) == 0
    with move_stopped_at(monkeypatch, out / "frame_0001" / "left.png"):                          # Ctrl-C
        assert main(["scene", "--out", str(out), "--size", "48x36", "--seed", "4", "--frames", "2"]) == 130
    assert not holds_a_scene(out / "frame_0001")
    from stereo_obstacles.datasets import load_pair
    from stereo_obstacles.errors import InputFileError
    for frame in ("frame_0000", "frame_0001"):                           # nor to the dataset reader (review)
        with pytest.raises(InputFileError, match=rf"{frame}: the writing of its files was cut short \(.* may be of "
                                                 r"another run than the rest\); write them again"):
            load_pair(out / frame)
    (out / "frame_0001" / ".DS_Store").write_bytes(b"")                 # a note beside it does not matter (review)
    assert main(["scene", "--out", str(out), "--size", "48x36", "--seed", "4", "--frames", "2"]) == 0   # replaced
    assert all(json.loads((out / f / "scene.json").read_text())["seed"] == 4 for f in ("frame_0000", "frame_0001"))
    assert all(load_pair(out, frame=frame).layout == "synthetic" for frame in ("frame_0000", "frame_0001"))


def test_an_earlier_frame_that_cannot_be_removed_is_an_error_not_a_crash(tmp_path, capsys):
    out = tmp_path / "walk"
    assert main(["scene", "--out", str(out), "--size", "48x36", "--frames", "3"]) == 0
    (out / "frame_0002" / "left.png").unlink()
    (out / "frame_0002" / "left.png").mkdir()                               # a folder where a file was
    assert main(["scene", "--out", str(out), "--size", "48x36", "--frames", "2"]) == 0
    assert not (out / "frame_0002" / "scene.json").exists()                # no longer a frame
    assert (out / "frame_0002" / "left.png").is_dir()                      # what is not a scene file stays


def test_a_sequence_into_a_link_to_a_single_scene_replaces_the_scene(tmp_path):
    from stereo_obstacles.datasets import list_frames

    assert main(["scene", "--out", str(tmp_path / "real"), "--size", "48x36"]) == 0
    (tmp_path / "link").symlink_to(tmp_path / "real")
    assert main(["scene", "--out", str(tmp_path / "link"), "--size", "48x36", "--frames", "2"]) == 0
    assert sorted(p.name for p in (tmp_path / "real").iterdir()) == ["frame_0000", "frame_0001"]
    assert list_frames(tmp_path / "link") == ("frame_0000", "frame_0001")


def test_a_single_scene_is_refused_over_files_that_are_not_a_scenes(tmp_path, capsys, monkeypatch):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "left.png").write_bytes(b"my picture")
    (out / "notes.txt").write_text("mine")
    rendered = []
    import stereo_obstacles.synthetic as synthetic

    monkeypatch.setattr(synthetic, "render_pair", lambda *a, **k: rendered.append(1))
    assert main(["scene", "--out", str(out), "--size", "48x36"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "holds left.png but no scene of this tool" in err
    assert rendered == [] and (out / "left.png").read_bytes() == b"my picture"
    assert sorted(p.name for p in out.iterdir()) == ["left.png", "notes.txt"]


def test_a_scene_over_a_detection_report_is_refused_and_over_a_scene_replaces_it(tmp_path, capsys):
    out = tmp_path / "report"
    out.mkdir()
    (out / "obstacles.json").write_text(json.dumps({"format": "stereo-obstacles/obstacles", "version": 1}))
    (out / "index.html").write_text("<html>a report</html>")
    assert main(["scene", "--out", str(out), "--size", "48x36"]) == 1
    assert "holds obstacles.json but no scene of this tool" in capsys.readouterr().err
    scene = tmp_path / "scene"
    assert main(["scene", "--out", str(scene), "--size", "48x36", "--seed", "3"]) == 0
    assert main(["scene", "--out", str(scene), "--size", "48x36", "--seed", "4"]) == 0
    assert json.loads((scene / "scene.json").read_text())["seed"] == 4


def test_demo_refuses_a_scene_folder_of_the_users_files(tmp_path, capsys, monkeypatch):
    out = tmp_path / "demo"
    (out / "scene").mkdir(parents=True)
    (out / "scene" / "left.png").write_bytes(b"my picture")
    rendered = []
    import stereo_obstacles.synthetic as synthetic

    monkeypatch.setattr(synthetic, "render_pair", lambda *a, **k: rendered.append(1))
    assert main(["demo", "--out", str(out), "--size", "64x48"]) == 1
    assert "holds left.png but no scene of this tool" in capsys.readouterr().err and rendered == []
    assert (out / "scene" / "left.png").read_bytes() == b"my picture" and not (out / "index.html").exists()


def test_write_scene_folder_keeps_a_users_files(tmp_path):
    from stereo_obstacles.errors import OutputError
    from stereo_obstacles.synthetic import write_scene_folder

    (tmp_path / "calibration.json").write_text("my rig")
    with pytest.raises(OutputError, match="holds calibration.json but no scene of this tool"):
        write_scene_folder(tmp_path, render_pair(default_scene(48, 36)))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["calibration.json"]
    written = write_scene_folder(tmp_path / "new", render_pair(default_scene(48, 36)))   # what it says it wrote
    assert sorted(written) == sorted((tmp_path / "new").iterdir())


def test_a_scene_with_a_mis_mounted_right_camera_comes_with_its_true_calibration(tmp_path, capsys):
    from stereo_obstacles.camera_calibration import read_camera_pair_json

    out = tmp_path / "tilted"
    assert main(["scene", "--out", str(out), "--size", "160x120", "--right-rotation-deg", "0.5", "1", "0.5"]) == 0
    assert "rectify the pair with --calib" in capsys.readouterr().out
    rig = read_camera_pair_json(out / "camera_pair.json")
    truth = json.loads((out / "scene.json").read_text())
    assert "camera_pair.json" in truth["files"] and (rig.width_px, rig.height_px) == (160, 120)
    true_pose = truth["right_camera"]
    for ours, theirs in ((rig.rotation, "R"), (rig.translation_m, "T"), (rig.camera_matrix_left, "K_left"),
                         (rig.camera_matrix_right, "K_right")):
        assert np.allclose(ours, true_pose[theirs], atol=1e-5)
    rectified = tmp_path / "rectified"
    assert main(["rectify", str(out / "left.png"), str(out / "right.png"), "--calib", str(out / "camera_pair.json"),
                 "--out", str(rectified)]) == 0
    report = json.loads((rectified / "rectification.json").read_text())
    assert report["features_before"]["vertical_offset"]["median_px"] > 1.0
    assert report["features_after"]["vertical_offset"]["median_px"] < 0.5
    # rendered again without the error into the same folder: the pair is rectified, the file goes
    assert main(["scene", "--out", str(out), "--size", "160x120"]) == 0
    assert not (out / "camera_pair.json").exists()
    assert "camera_pair.json" not in json.loads((out / "scene.json").read_text())["files"]


def test_a_rectified_sequence_over_a_mis_mounted_one_leaves_no_calibration_of_the_old_frames(tmp_path, capsys):
    out = tmp_path / "walk"
    assert main(["scene", "--out", str(out), "--size", "64x48", "--frames", "2", "--right-offset-px", "2"]) == 0
    assert "frame_*" in capsys.readouterr().out and (out / "frame_0001" / "camera_pair.json").exists()
    assert main(["scene", "--out", str(out), "--size", "64x48", "--frames", "2"]) == 0
    assert not list(out.glob("frame_*/camera_pair.json"))


def test_single_file_writers_refuse_to_replace_a_scenes_files(tmp_path, capsys):
    # segment -o scene/labels.png replaced the scene's ground truth, exit 0 (user-level review, session 23)
    from stereo_obstacles.errors import OutputError
    from stereo_obstacles.synthetic.scene_files import refuse_scene_files

    scene = tmp_path / "scene"
    assert main(["scene", "--out", str(scene), "--size", "160x120"]) == 0
    truth = {name: (scene / name).read_bytes() for name in ("labels.png", "disparity.pfm")}
    for command in (["segment", str(scene / "left.png"), "-o", str(scene / "labels.png")],
                    ["disparity", str(scene / "left.png"), str(scene / "right.png"), "-o", str(scene / "disparity.pfm")]):
        capsys.readouterr()
        assert main(command) == 1
        assert "is a file of the rendered scene in" in capsys.readouterr().err
    assert {name: (scene / name).read_bytes() for name in truth} == truth
    with pytest.raises(OutputError, match="calibration.json is a file of the rendered scene"):
        refuse_scene_files(None, scene / "calibration.json")          # calibrate --out
    refuse_scene_files(scene / "mine.png", tmp_path / "labels.png")   # other names, or not in a scene: written
    assert main(["segment", str(scene / "left.png"), "-o", str(scene / "mine.png")]) == 0


def test_a_mis_mounted_sequence_names_a_calibration_file_that_exists(tmp_path, capsys):
    # the hint named "seq/frame_*/camera_pair.json", a pattern no --calib reads (user-level review, session 23)
    out = tmp_path / "seq"
    assert main(["scene", "--out", str(out), "--frames", "2", "--size", "160x120", "--right-rotation-deg", "0", "1",
                 "0"]) == 0
    hint = next(line for line in capsys.readouterr().out.splitlines() if "--calib" in line)
    named = hint.split("--calib ")[1].split()[0]
    assert named == str(out / "frame_0000" / "camera_pair.json") and os.path.isfile(named)
