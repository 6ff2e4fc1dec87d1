"""A killed run leaves no output that looks complete; a few end-to-end runs as a user would."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import pytest

COMMAND = [sys.executable, "-m", "stereo_obstacles"]


def test_end_to_end_errors_are_one_line_without_traceback(inputs, tmp_path):
    done = subprocess.run([*COMMAND, "detect", inputs / "truncated.png", inputs / "right.png", "--out",
                           tmp_path / "o"], capture_output=True, text=True, timeout=120)
    assert done.returncode == 1
    assert "Traceback" not in done.stderr
    assert done.stderr.strip().splitlines()[-1].startswith("stereo-obstacles: error:")


@pytest.mark.parametrize("delay_s", [0.3, 1.0, 1.6])
def test_sigkill_during_detect_leaves_the_report_absent_or_complete(inputs, tmp_path, delay_s):
    out = tmp_path / "o"
    out.mkdir()
    (out / "index.html").write_text("from an older run")
    process = subprocess.Popen([*COMMAND, "detect", inputs / "left.png", inputs / "right.png", "--out", out,
                                "--calib", inputs / "scene" / "calibration.json"],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    time.sleep(delay_s)
    process.send_signal(signal.SIGKILL)
    process.wait(timeout=30)
    report = out / "obstacles.json"
    if report.exists():  # a finished run: the whole set is there and parses
        assert "obstacles" in json.loads(report.read_text())
        assert (out / "index.html").read_text().rstrip().endswith("</html>")
        for name in ("disparity.pfm", "labels.png", "depth.npy", "points.ply"):
            assert (out / name).stat().st_size > 0
    else:
        html = out / "index.html"
        assert not html.exists() or html.read_text() == "from an older run"
    leftovers = [p.name for p in out.iterdir() if ".part" in p.name]
    assert leftovers == []


def test_sigkill_during_video_leaves_complete_json_lines(inputs, tmp_path):
    import shutil

    for side in ("left", "right"):
        folder = tmp_path / side
        folder.mkdir()
        for k in range(6):
            shutil.copy(inputs / f"{side}.png", folder / f"{k:04d}.png")
    jsonl = tmp_path / "v.jsonl"
    process = subprocess.Popen([*COMMAND, "video", "--kind", "images", tmp_path / "left", tmp_path / "right",
                                "--jsonl", jsonl], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and (not jsonl.exists() or jsonl.read_text().count("\n") < 2):
        time.sleep(0.05)
    process.send_signal(signal.SIGKILL)
    process.wait(timeout=30)
    text = jsonl.read_text()
    assert text.endswith("\n")
    records = [json.loads(line) for line in text.splitlines()]
    assert len(records) >= 2


def test_ctrl_c_exits_130_without_traceback(inputs, tmp_path):
    process = subprocess.Popen([*COMMAND, "demo", "--out", tmp_path / "demo"], stdout=subprocess.DEVNULL,
                               stderr=subprocess.PIPE, text=True)
    time.sleep(1.0)
    os.kill(process.pid, signal.SIGINT)
    _, err = process.communicate(timeout=60)
    assert process.returncode in (0, 130)
    assert "Traceback" not in err
    if process.returncode == 130:
        assert not (tmp_path / "demo" / "index.html").exists() or (tmp_path / "demo" / "obstacles.json").exists()
