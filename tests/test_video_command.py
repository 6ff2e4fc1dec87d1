"""The video command: JSON lines, annotated video, per-frame outputs, temporal seeds, interruption."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from io import StringIO

import cv2
import pytest

from _stream_frames import N_FRAMES, SIZE, frames, write_calibration, write_side_by_side, write_sequences, write_videos
from stereo_obstacles.cli import main
from stereo_obstacles.errors import InputFileError
from stereo_obstacles.jsonl import JsonLinesWriter, read_json_lines
from stereo_obstacles.progress import Progress


def test_video_pair_gives_tracked_obstacles_as_json_lines_and_a_video(tmp_path):
    left, right = write_videos(tmp_path / "in")
    calib = write_calibration(tmp_path / "calib.json")
    jsonl, out_video = tmp_path / "frames.jsonl", tmp_path / "out" / "annotated.mp4"
    code = main(["video", str(left), str(right), "--calib", str(calib), "--jsonl", str(jsonl),
                 "--video-out", str(out_video), "--forward-speed", "0.1"])
    assert code == 0
    records = read_json_lines(jsonl)
    header, frames, end = records[0], records[1:-1], records[-1]
    assert header["type"] == "header" and header["units"] == "metres" and header["calibration"] is not None
    assert [r["frame"] for r in frames] == list(range(N_FRAMES))
    # three frames in flight: the first three start before any is done; the fourth refines the first
    assert [r["seeds"] for r in frames] == ["edge", "edge", "edge", "refined"][:N_FRAMES]
    assert end == {**end, "type": "end", "frames": N_FRAMES, "interrupted": False}
    # The detector is unsteady on 160x120 MJPG frames (objects merge and split), so only the
    # wiring is checked here; tracking itself is tested in test_tracking.py.
    ids = [{o["track_id"] for o in r["obstacles"]} for r in frames]
    assert all(ids) and set.intersection(*ids)                 # some obstacle keeps its id throughout
    for record in frames:
        for o in record["obstacles"]:
            assert isinstance(o["approaching"], bool) and o["measured_distance_m"] > 0 and o["distance_m"] > 0
            assert (o["closing_speed_mps"] is not None) and o["age_frames"] >= 1
    capture = cv2.VideoCapture(str(out_video))
    assert int(capture.get(cv2.CAP_PROP_FRAME_COUNT)) == N_FRAMES
    assert (int(capture.get(cv2.CAP_PROP_FRAME_WIDTH)), int(capture.get(cv2.CAP_PROP_FRAME_HEIGHT))) == SIZE
    capture.release()
    assert [p.name for p in out_video.parent.iterdir()] == ["annotated.mp4"]     # no temporary left
    mask = os.umask(0)
    os.umask(mask)
    assert out_video.stat().st_mode & 0o777 == 0o666 & ~mask    # a plain file's mode, not the temp file's 0600


def test_image_sequences_without_temporal_seeds_and_with_frame_outputs(tmp_path, capsys):
    left_dir, right_dir = write_sequences(tmp_path / "in")
    code = main(["video", str(left_dir), str(right_dir), "--no-temporal-seeds", "--max-frames", "2",
                 "--frames-out", str(tmp_path / "frames")])
    assert code == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert len(lines) == 2 and lines[0].startswith("frame 0 t=0.00 s: #1 d=")      # no calibration: pixels
    assert sorted(p.name for p in (tmp_path / "frames").iterdir()) == ["0000", "0001"]
    inputs = json.loads((tmp_path / "frames" / "0001" / "obstacles.json").read_text())["run"]["inputs"]
    assert inputs["rectification_check"]["rectified"] is True and inputs["rectification_check"]["frame"] == 0


@pytest.mark.parametrize("kind", ["videos", "sequences"])
def test_one_source_given_twice_is_refused(tmp_path, capsys, kind):
    """It printed "no obstacles" for every frame, after a warning."""
    left, _ = write_videos(tmp_path / "in") if kind == "videos" else write_sequences(tmp_path / "in")
    assert main(["video", str(left), f"{left.parent}/./{left.name}", "--jsonl", str(tmp_path / "f.jsonl")]) == 1
    assert "are one and the same; a stereo pair needs the two cameras' images" in capsys.readouterr().err
    assert not (tmp_path / "f.jsonl").exists()


def test_side_by_side_video_to_stdout_jsonl(tmp_path, capfd):
    video = write_side_by_side(tmp_path / "sbs.avi")
    assert main(["video", str(video), "--max-frames", "1", "--jsonl", "-"]) == 0
    records = [json.loads(line) for line in capfd.readouterr().out.splitlines()]
    assert [r["type"] for r in records] == ["header", "frame", "end"]
    assert records[0]["source"].startswith("side-by-side video")


def test_empty_source_is_an_error(tmp_path, capsys):
    (tmp_path / "l").mkdir()
    (tmp_path / "r").mkdir()
    assert main(["video", str(tmp_path / "l"), str(tmp_path / "r")]) == 1
    assert "no image files" in capsys.readouterr().err


@pytest.mark.parametrize("option, message", [(["--in-flight", "0"], "--in-flight must be >= 1, got 0"),
                                             (["--max-frames", "0"], "--max-frames must be >= 1, got 0")])
def test_bad_counts_are_one_line_errors(tmp_path, capsys, option, message):
    left_dir, right_dir = write_sequences(tmp_path / "in")
    assert main(["video", str(left_dir), str(right_dir), *option]) == 1
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_odd_sized_frames_give_a_video_padded_by_one_black_row(tmp_path):
    left_dir, right_dir = write_sequences(tmp_path / "in")
    for image in [*left_dir.iterdir(), *right_dir.iterdir()]:        # 160 x 119: an odd height
        cv2.imwrite(str(image), cv2.imread(str(image))[:-1])
    out_video = tmp_path / "annotated.mp4"
    assert main(["video", str(left_dir), str(right_dir), "--max-frames", "1", "--video-out", str(out_video)]) == 0
    capture = cv2.VideoCapture(str(out_video))
    ok, frame = capture.read()
    capture.release()
    assert ok and frame.shape[:2] == (120, 160)                     # not cropped to 118 rows
    assert frame[-1].max() < 40 < frame[-2].max()                   # the added row is black, the last image row is not


def test_an_output_naming_an_image_a_pattern_matches_is_refused(tmp_path, capsys):
    # with folders the same mistake was refused; with glob patterns the image was replaced, exit 0 (review)
    left_dir, right_dir = write_sequences(tmp_path / "in")
    image = left_dir / "0002.png"
    before = image.read_bytes()
    assert main(["video", str(left_dir / "*.png"), str(right_dir / "*.png"), "--jsonl", str(image),
                 "--max-frames", "1"]) == 1
    assert "is also an input or another output of this run" in capsys.readouterr().err
    assert image.read_bytes() == before
    # one the pattern would match once written: the next run read it as a frame (review)
    assert main(["video", str(left_dir / "*"), str(right_dir / "*"), "--jsonl", str(left_dir / "track.jsonl"),
                 "--max-frames", "1"]) == 1
    assert "track.jsonl matches the source pattern" in capsys.readouterr().err
    assert not (left_dir / "track.jsonl").exists()


def test_a_video_writer_opencv_refuses_costs_no_earlier_jsonl_file(tmp_path, capsys):
    left_dir, right_dir = write_sequences(tmp_path / "in")
    jsonl = tmp_path / "keep.jsonl"
    jsonl.write_text('{"type": "header"}\n{"type": "frame"}\n')
    assert main(["video", str(left_dir), str(right_dir), "--jsonl", str(jsonl), "--video-out",
                 str(tmp_path / "o.xyz")]) == 1
    assert "cannot write video" in capsys.readouterr().err
    assert jsonl.read_text() == '{"type": "header"}\n{"type": "frame"}\n'       # was emptied to a new header


@pytest.mark.parametrize("option, message", [(["--forward-speed", "0.5"], "--forward-speed needs a calibration"),
                                             (["--video-out", "{tmp}"], "is a folder; expected a file name"),
                                             (["--jsonl", "{tmp}"], "is a folder; expected a file name"),
                                             (["--video-out", "{tmp}/v.png"], "names an image; give a video file")])
def test_options_that_cannot_work_are_refused_before_any_frame(tmp_path, capsys, option, message):
    left_dir, right_dir = write_sequences(tmp_path / "in")
    option = [o.format(tmp=tmp_path) for o in option]
    assert main(["video", str(left_dir), str(right_dir), *option]) == 1
    captured = capsys.readouterr()
    assert message in captured.err and "Traceback" not in captured.err and "frame 0" not in captured.out


def test_a_swapped_stream_is_refused_on_its_first_frame_before_any_output(tmp_path, capsys, caplog):
    left_dir, right_dir = write_sequences(tmp_path / "in")
    jsonl, out_video = tmp_path / "frames.jsonl", tmp_path / "annotated.mp4"
    assert main(["video", str(right_dir), str(left_dir), "--jsonl", str(jsonl), "--video-out", str(out_video)]) == 1
    assert "look swapped" in capsys.readouterr().err
    assert "look swapped" not in caplog.text                              # the error alone says it, once
    assert list(tmp_path.iterdir()) == [tmp_path / "in"]                  # no header-only JSON lines, no video


def test_a_warning_of_every_frame_is_shown_once(tmp_path, capsys, caplog):
    left_dir, right_dir = write_sequences(tmp_path / "in")
    with caplog.at_level("WARNING"):
        assert main(["video", str(left_dir), str(right_dir), "--max-disparity", "3", "--no-temporal-seeds"]) == 0
    assert caplog.text.count("lie at the largest disparity searched, 3 px") == 1      # not once per frame
    err = capsys.readouterr().err
    assert f"processed {N_FRAMES} frames" in err and "repeats of the warnings above not shown" in err
    caplog.clear()
    with caplog.at_level("WARNING"):                                    # -v: everything, every frame
        assert main(["-v", "video", str(left_dir), str(right_dir), "--max-disparity", "3", "--no-temporal-seeds"]) == 0
    assert caplog.text.count("lie at the largest disparity searched, 3 px") == N_FRAMES


def _run_and_stop(tmp_path, how: int) -> tuple[int, list[str], str]:
    """Start the command on a long sequence, stop it with ``how`` once two frames are written."""
    left_dir, right_dir = write_sequences(tmp_path / "in", repeat=25)
    jsonl = tmp_path / "frames.jsonl"
    process = subprocess.Popen([sys.executable, "-m", "stereo_obstacles", "video", str(left_dir), str(right_dir),
                                "--jsonl", str(jsonl)], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and process.poll() is None:
        if jsonl.exists() and jsonl.read_bytes().count(b"\n") >= 3:
            break
        time.sleep(0.05)
    process.send_signal(how)
    _, err = process.communicate(timeout=60)
    return process.returncode, jsonl.read_bytes().decode().splitlines(keepends=True), err.decode()


def test_ctrl_c_stops_cleanly_with_only_complete_lines(tmp_path):
    code, lines, err = _run_and_stop(tmp_path, signal.SIGINT)
    assert code == 130, err
    records = [json.loads(line) for line in lines]
    assert all(line.endswith("\n") for line in lines)
    assert records[-1]["type"] == "end" and records[-1]["interrupted"] is True
    assert 2 <= records[-1]["frames"] < 100 and len(records) == records[-1]["frames"] + 2


def _stop_on_call(real, n: int, stop):
    """``real`` wrapped so that its ``n``-th call first calls ``stop`` (which raises, or sends a signal)."""
    calls = []

    def wrapped(*args, **kwargs):
        calls.append(1)
        if len(calls) == n:
            stop()
        return real(*args, **kwargs)
    return wrapped


def _raise_terminated():
    from stereo_obstacles.interrupts import Terminated

    raise Terminated


def _send_sigterm():
    os.kill(os.getpid(), signal.SIGTERM)


def _every_output_of_a_stopped_run(tmp_path) -> tuple[int, list[dict], int, int]:
    """Run video with --jsonl, --video-out and --frames-out: the exit code, the JSON records, and
    the numbers of frame reports and of video frames written."""
    left_dir, right_dir = write_sequences(tmp_path / "in")
    jsonl, out_video, frames_out = tmp_path / "f.jsonl", tmp_path / "v.mp4", tmp_path / "fo"
    code = main(["video", str(left_dir), str(right_dir), "--jsonl", str(jsonl), "--video-out", str(out_video),
                 "--frames-out", str(frames_out)])
    capture = cv2.VideoCapture(str(out_video))
    video_frames = int(capture.get(cv2.CAP_PROP_FRAME_COUNT))
    capture.release()
    return code, read_json_lines(jsonl), len(list(frames_out.iterdir())), video_frames


def test_a_shorter_rerun_removes_the_frame_reports_of_the_earlier_run(tmp_path, capsys, monkeypatch, caplog):
    # they stayed beside the new ones, calibrated among uncalibrated (user-level review, session 23)
    left_dir, right_dir = write_sequences(tmp_path / "in")
    frames_out = tmp_path / "fo"
    assert main(["video", str(left_dir), str(right_dir), "--frames-out", str(frames_out)]) == 0
    assert len(list(frames_out.iterdir())) == N_FRAMES
    (frames_out / "notes").mkdir()
    (frames_out / "notes" / "mine.txt").write_text("x")
    # a report of detect, and the frames of another source, are not this run's to remove (review)
    assert main(["detect", str(left_dir / "0000.png"), str(right_dir / "0000.png"), "--out",
                 str(frames_out / "my_detect_run")]) == 0
    other = tmp_path / "other"
    other.mkdir()
    for side in ("left", "right"):
        (other / side).mkdir()
        for i in range(N_FRAMES):
            (other / side / f"{i + 10:04d}.png").write_bytes((tmp_path / "in" / side / f"{i:04d}.png").read_bytes())
    assert main(["video", str(other / "left"), str(other / "right"), "--frames-out", str(frames_out),
                 "--max-frames", "1"]) == 0
    kept = sorted(["notes", "my_detect_run", "0010"] + [f"{i:04d}" for i in range(N_FRAMES)])
    assert sorted(p.name for p in frames_out.iterdir()) == kept
    # an interrupted rerun keeps them all: it did not write the frames that would replace them
    from stereo_obstacles import report

    with monkeypatch.context() as patched:
        patched.setattr(report, "write_detection_outputs", _stop_on_call(report.write_detection_outputs, 2,
                                                                          _raise_terminated))
        assert main(["video", str(left_dir), str(right_dir), "--frames-out", str(frames_out),
                     "--max-frames", "2"]) == 143
    assert sorted(p.name for p in frames_out.iterdir()) == kept
    capsys.readouterr()
    import shutil                       # the staging folder a frame's move cut short keeps is no frame report (review)
    shutil.copytree(frames_out / "0003", frames_out / ".0003.@killed00.moving")
    with caplog.at_level("WARNING", logger="stereo_obstacles"):
        assert main(["video", str(left_dir), str(right_dir), "--frames-out", str(frames_out), "--max-frames", "2"]) == 0
    assert f"removed {N_FRAMES - 2} frame reports of an earlier run over this source" in capsys.readouterr().err
    assert (frames_out / ".0003.@killed00.moving" / "obstacles.json").is_file()
    shutil.rmtree(frames_out / ".0003.@killed00.moving")
    assert "also holds 1 frame report of another source (or of this one named otherwise)" in caplog.text
    assert sorted(p.name for p in frames_out.iterdir()) == sorted(["notes", "my_detect_run", "0010", "0000", "0001"])


@pytest.mark.parametrize("module, name, call, stop", [("report", "write_detection_outputs", 3, _raise_terminated),
                                                     ("stream_detection", "annotate_frame", 2, _send_sigterm)])
def test_a_frame_stopped_while_it_is_written_is_in_all_outputs_or_none(tmp_path, monkeypatch, module, name, call,
                                                                       stop):
    # a SIGTERM while the frame's --frames-out report was written left its JSON line and video frame in,
    # the count and the report out: 10 lines against "frames": 9 (user-level review, session 23). Raised in
    # the report, the frame is in no output; sent while its video frame is drawn, it waits for them all
    import importlib

    target = importlib.import_module(f"stereo_obstacles.{module}")
    monkeypatch.setattr(target, name, _stop_on_call(getattr(target, name), call, stop))
    code, records, reports, video_frames = _every_output_of_a_stopped_run(tmp_path)
    assert code == 143 and len(records) == 4 and records[-1]["frames"] == 2 and records[-1]["interrupted"]
    assert reports == video_frames == 2


def test_a_frame_that_cannot_be_read_ends_the_json_lines_with_the_error(tmp_path, capsys):
    # the lines stopped without an end line, as if the run had been killed (user-level review, session 23)
    left_dir, right_dir = write_sequences(tmp_path / "in")
    (left_dir / "0002.png").write_bytes(b"\x89PNG\r\n\x1a\n truncated")
    jsonl = tmp_path / "f.jsonl"
    assert main(["video", str(left_dir), str(right_dir), "--jsonl", str(jsonl)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "0002.png" in err
    end = read_json_lines(jsonl)[-1]
    assert end["type"] == "end" and end["frames"] == 2 and not end["interrupted"] and "0002.png" in end["error"]


def test_a_frame_report_is_not_written_over_a_rendered_scene(tmp_path, capsys):
    from stereo_obstacles.synthetic import write_scene_folder

    left_dir, right_dir = write_sequences(tmp_path / "in")
    write_scene_folder(tmp_path / "fo" / "0000", frames()[0])
    truth = (tmp_path / "fo" / "0000" / "obstacles.json").read_bytes()
    assert main(["video", str(left_dir), str(right_dir), "--frames-out", str(tmp_path / "fo"), "--max-frames", "1"]) == 1
    assert "holds a rendered scene" in capsys.readouterr().err
    assert (tmp_path / "fo" / "0000" / "obstacles.json").read_bytes() == truth
    # nor over a user's own files of the report's names in a frame folder (review, session 24)
    (tmp_path / "fo2" / "0000").mkdir(parents=True)
    (tmp_path / "fo2" / "0000" / "index.html").write_text("my page")
    assert main(["video", str(left_dir), str(right_dir), "--frames-out", str(tmp_path / "fo2"), "--max-frames", "1"]) == 1
    assert "holds index.html but no report of this tool" in capsys.readouterr().err
    assert (tmp_path / "fo2" / "0000" / "index.html").read_text() == "my page"


def test_options_of_the_temporal_seeds_are_said_to_do_nothing_without_them(tmp_path, caplog):
    # --no-temporal-seeds silently ignored --seed-step, --refine-frames and --forward-speed (review, session 23)
    left_dir, right_dir = write_sequences(tmp_path / "in")
    with caplog.at_level("WARNING", logger="stereo_obstacles"):
        assert main(["video", str(left_dir), str(right_dir), "--no-temporal-seeds", "--seed-step", "4",
                     "--refine-frames", "0", "--max-frames", "1"]) == 0
        assert "--seed-step, --refine-frames do nothing with --no-temporal-seeds" in caplog.text
        caplog.clear()                # not also refused for want of a calibration it would not use (review)
        assert main(["video", str(left_dir), str(right_dir), "--no-temporal-seeds", "--forward-speed", "0.1",
                     "--max-frames", "1"]) == 0
        assert "--forward-speed does nothing with --no-temporal-seeds" in caplog.text
        caplog.clear()
        assert main(["video", str(left_dir), str(right_dir), "--seed-step", "4", "--max-frames", "1"]) == 0
        assert "do nothing" not in caplog.text and "does nothing" not in caplog.text


def test_sigterm_stops_at_once_with_complete_lines_and_exit_143(tmp_path):
    code, lines, err = _run_and_stop(tmp_path, signal.SIGTERM)
    assert code == 143, err
    records = [json.loads(line) for line in lines]
    assert records[-1]["type"] == "end" and records[-1]["interrupted"] is True


def test_killed_run_leaves_only_complete_lines(tmp_path):
    code, lines, _ = _run_and_stop(tmp_path, signal.SIGKILL)
    assert code == -signal.SIGKILL
    assert len(lines) >= 3 and all(line.endswith("\n") for line in lines)
    assert [json.loads(line)["type"] for line in lines[1:]] == ["frame"] * (len(lines) - 1)


def test_json_lines_reader_reports_a_torn_line(tmp_path):
    path = tmp_path / "x.jsonl"
    with JsonLinesWriter(path, sync=False) as out:
        out.write({"a": 1})
    with open(path, "a") as f:
        f.write('{"a": ')
    with pytest.raises(InputFileError, match="line 2 is incomplete"):
        read_json_lines(path)
    path.write_text('{"a": 1}\n{"a": \n')
    with pytest.raises(InputFileError, match="line 2 is not valid JSON"):
        read_json_lines(path)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="named pipes are POSIX")
def test_json_lines_go_to_a_named_pipe_and_to_dev_null(tmp_path):
    # fsync of a pipe or a device fails (EINVAL): a robot reading the frames through a FIFO got an error
    fifo = tmp_path / "frames"
    os.mkfifo(fifo)
    got = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_text()))
    reader.start()
    with JsonLinesWriter(fifo) as out:
        out.write({"frame": 0})
        out.write({"frame": 1})
    reader.join(timeout=30)
    assert got == ['{"frame":0}\n{"frame":1}\n']
    with JsonLinesWriter(os.devnull) as out:
        out.write({"frame": 0})
    assert out.lines == 1


def test_dev_null_is_an_output_for_a_user_who_cannot_write_in_dev(tmp_path, monkeypatch):
    # the folder's trial file and write check refused /dev/null to every user but root (review)
    from stereo_obstacles.atomic import check_output_file

    real_access = os.access
    monkeypatch.setattr(os, "access", lambda path, mode, **kw: False if os.fspath(path) == os.path.dirname(os.devnull)
                        else real_access(path, mode, **kw))
    check_output_file(os.devnull)
    with JsonLinesWriter(os.devnull) as out:
        out.write({"frame": 0})
    left_dir, right_dir = write_sequences(tmp_path / "in")
    assert main(["video", str(left_dir), str(right_dir), "--jsonl", os.devnull, "--max-frames", "1"]) == 0


def test_progress_draws_only_when_enabled():
    stream = StringIO()
    progress = Progress(4, stream=stream, enabled=True, interval_s=0.0)
    for _ in range(4):
        progress.update(note="x")
    progress.close()
    assert "frame 4/4 [####################]" in stream.getvalue()
    quiet = StringIO()
    Progress(4, stream=quiet).update()            # StringIO is not a terminal
    assert quiet.getvalue() == ""
    live = Progress(None, label="frame", stream=StringIO(), enabled=True)
    live.update()
    assert live.line().startswith("frame 1 ")


class _FakeCamera:
    """Stands in for ``cv2.VideoCapture(index)``: devices 0 and 1 deliver the synthetic frames
    (left and right) and then stop, as a camera that is unplugged."""

    def __init__(self, index):
        from _stream_frames import _bgr, frames

        self.images = [_bgr(pair.left if index == 0 else pair.right) for pair in frames()] if index in (0, 1) else None
        self.position = -1

    def isOpened(self):
        return self.images is not None

    def set(self, prop, value):
        return True

    def get(self, prop):
        return 30.0 if prop == cv2.CAP_PROP_FPS else 0.0

    def grab(self):
        self.position += 1
        return self.position < len(self.images)

    def retrieve(self):
        return True, self.images[self.position].copy()

    def release(self):
        self.images = []


def test_two_live_cameras_simulated(tmp_path, monkeypatch, capsys):
    """The camera path end to end with a simulated capture device (no camera on this machine)."""
    import stereo_obstacles.streams as streams

    monkeypatch.setattr(streams.cv2, "VideoCapture", _FakeCamera)
    calib = write_calibration(tmp_path / "calib.json")
    jsonl = tmp_path / "live.jsonl"
    assert main(["video", "0", "1", "--calib", str(calib), "--jsonl", str(jsonl)]) == 0
    records = read_json_lines(jsonl)
    assert "cameras 0 and 1" in records[0]["source"]
    frames = [r for r in records if r.get("type") == "frame"]
    assert [r["frame"] for r in frames] == list(range(N_FRAMES))
    assert all(r["obstacles"] for r in frames)
    assert records[-1]["frames"] == N_FRAMES and records[-1]["frames_per_second"] > 0
    err = capsys.readouterr().err
    assert "a camera stopped delivering frames" in err or f"processed {N_FRAMES} frames" in err
    with pytest.raises(InputFileError, match="camera 7 cannot be opened"):
        streams.CameraPairSource(0, 7)


def test_help_defaults_are_the_library_defaults():
    import argparse

    from stereo_obstacles.commands.video import register
    from stereo_obstacles.stream_detection import IN_FLIGHT
    from stereo_obstacles.temporal_seeds import TemporalSeedParameters

    subparsers = argparse.ArgumentParser().add_subparsers()
    register(subparsers)
    text = " ".join(subparsers.choices["video"].format_help().split())
    assert f"(default {IN_FLIGHT}:" in text and f"(default {TemporalSeedParameters().refine_frames};" in text


def test_a_calibration_of_the_raw_cameras_rectifies_every_frame(tmp_path, capsys):
    # calibrate writes the raw cameras' calibration; video refused it as a "malformed" file
    from _rectification_cases import synthetic_case
    from stereo_obstacles.camera_calibration import write_camera_pair_json

    pair, rig = synthetic_case()
    for side in ("left", "right"):
        (tmp_path / side).mkdir()
        for i in range(2):
            cv2.imwrite(str(tmp_path / side / f"{i}.png"), cv2.cvtColor(getattr(pair, side), cv2.COLOR_RGB2BGR))
    write_camera_pair_json(tmp_path / "rig.json", rig)
    assert main(["video", str(tmp_path / "left"), str(tmp_path / "right"), "--calib", str(tmp_path / "rig.json"),
                 "--jsonl", str(tmp_path / "f.jsonl"), "--frames-out", str(tmp_path / "fo")]) == 0
    header, *records, end = read_json_lines(tmp_path / "f.jsonl")
    assert header["calibration"]["baseline_m"] == pytest.approx(rig.baseline_m, rel=1e-6)
    said = {"method": "calibrated", "calibration": str(tmp_path / "rig.json"), "rectified": header["calibration"]}
    assert header["rectification"] == said                 # the frames' rectification is said, as detect says it
    assert json.loads((tmp_path / "fo" / "1" / "obstacles.json").read_text())["run"]["inputs"]["rectification"] == said
    assert [r["type"] for r in records] == ["frame", "frame"] and end["type"] == "end"
    assert main(["detect", str(tmp_path / "left" / "0.png"), str(tmp_path / "right" / "0.png"), "--calib",
                 str(tmp_path / "rig.json"), "--out", str(tmp_path / "d")]) == 0
    detected = json.loads((tmp_path / "d" / "obstacles.json").read_text())["obstacles"]
    nearest = min(o["distance_m"] for o in detected)
    assert min(o["measured_distance_m"] for o in records[0]["obstacles"]) == pytest.approx(nearest, rel=0.02)
    assert nearest == pytest.approx(min(t.nearest_depth_m for t in pair.obstacles if t.nearest_depth_m), rel=0.05)
    small = cv2.resize(cv2.imread(str(tmp_path / "left" / "1.png")), (160, 120))
    cv2.imwrite(str(tmp_path / "left" / "1.png"), small)
    cv2.imwrite(str(tmp_path / "right" / "1.png"), small)
    capsys.readouterr()
    assert main(["video", str(tmp_path / "left"), str(tmp_path / "right"), "--calib", str(tmp_path / "rig.json")]) == 1
    assert "frame 1 (1): left image must be 320x240 like the rectification, got 160x120" in capsys.readouterr().err
