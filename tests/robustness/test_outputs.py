"""Unwritable and existing output folders; every writer leaves a complete file or none.

Running as root, permissions cannot make a folder unwritable (root writes anyway), so an
unwritable output is simulated by a path whose parent is a regular file.
"""

from __future__ import annotations

import json
import os

import pytest

from robustness._inputs import error_line
from stereo_obstacles.atomic import staged_directory


def _commands(inputs, out):
    pair = [inputs / "left.png", inputs / "right.png"]
    return {
        "detect": ["detect", *pair, "--out", out],
        "disparity": ["disparity", *pair, "-o", out / "d.npy"],
        "segment": ["segment", inputs / "left.png", "-o", out / "labels.png"],
        "scene": ["scene", "--out", out, "--size", "32x24"],
        "demo": ["demo", "--out", out, "--size", "32x24"],
        "evaluate --json": ["evaluate", inputs / "scene", "--methods", "bm", "--json", out / "e.json"],
        "evaluate-segmentation --json": ["evaluate-segmentation", "--scenes", "1", "--size", "32x24", "--json",
                                         out / "s.json"],
        "video --jsonl": ["video", "--kind", "images", inputs / "seq_left", inputs / "seq_right", "--jsonl",
                          out / "v.jsonl"],
        "batch": ["batch", inputs / "batch_in", "--out", out, "--workers", "1", "--task", "disparity"],
    }


@pytest.fixture(scope="module")
def sequences(inputs):
    import shutil

    for side in ("left", "right"):
        (inputs / f"seq_{side}").mkdir(exist_ok=True)
        shutil.copy(inputs / f"{side}.png", inputs / f"seq_{side}" / "0000.png")
    (inputs / "batch_in").mkdir(exist_ok=True)
    if not (inputs / "batch_in" / "p").exists():
        shutil.copytree(inputs / "scene", inputs / "batch_in" / "p")
    return inputs


@pytest.mark.parametrize("command", ["detect", "disparity", "segment", "scene", "demo", "evaluate --json",
                                     "evaluate-segmentation --json", "video --jsonl", "batch"])
def test_an_output_under_a_regular_file_is_one_line(sequences, run_cli, command):
    out = sequences / "a_file" / "sub"
    code, _, err, _ = run_cli(*_commands(sequences, out)[command])
    assert code == 1, err
    line = error_line(err)
    assert f"{sequences / 'a_file'}" in line


def test_an_output_folder_that_is_a_file_is_refused(inputs, run_cli):
    code, _, err, _ = run_cli("detect", inputs / "left.png", inputs / "right.png", "--out", inputs / "a_file")
    assert code == 1 and f"output folder {inputs / 'a_file'} exists and is not a folder" in error_line(err)
    assert (inputs / "a_file").read_text() == "x\n"


def test_an_existing_output_folder_is_updated_and_other_files_kept(inputs, run_cli, tmp_path):
    out = tmp_path / "o"
    assert run_cli("detect", inputs / "left.png", inputs / "right.png", "--out", out)[0] == 0   # an earlier report
    (out / "notes.txt").write_text("mine")
    (out / "obstacles.json").write_text(json.dumps({**json.loads((out / "obstacles.json").read_text()),
                                                    "obstacles": "old"}))
    code, _, _, _ = run_cli("detect", inputs / "left.png", inputs / "right.png", "--out", out)
    assert code == 0
    assert (out / "notes.txt").read_text() == "mine"
    assert isinstance(json.loads((out / "obstacles.json").read_text())["obstacles"], list)     # the new report
    (out / "obstacles.json").write_text("another tool's")                 # not a report: refused, left alone
    code, _, err, _ = run_cli("detect", inputs / "left.png", inputs / "right.png", "--out", out)
    assert code == 1 and "not a report of this tool" in err
    assert (out / "obstacles.json").read_text() == "another tool's"
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no staging folder left


def test_a_move_cut_short_leaves_no_report_beside_a_mix(tmp_path, monkeypatch):
    out = tmp_path / "o"
    out.mkdir()
    for name in ("a.png", "index.html", "z.png"):
        (out / name).write_text("old")
    real_replace = os.replace
    calls = []

    def replace_then_die(src, dst):
        calls.append(dst)
        if len(calls) == 2:
            raise KeyboardInterrupt  # stands for a kill between two renames
        real_replace(src, dst)

    monkeypatch.setattr(os, "replace", replace_then_die)
    with pytest.raises(KeyboardInterrupt):
        with staged_directory(out, last=("index.html",)) as stage:
            for name in ("a.png", "index.html", "z.png"):
                (stage / name).write_text("new")
    assert not (out / "index.html").exists()
    assert (out / "a.png").read_text() == "new"
    assert [p.name for p in calls][-1] != "index.html"


def test_staged_files_named_last_are_moved_last(tmp_path, monkeypatch):
    out = tmp_path / "o"
    out.mkdir()
    moved = []
    real_replace = os.replace
    monkeypatch.setattr(os, "replace", lambda src, dst: (moved.append(os.path.basename(dst)), real_replace(src, dst)))
    with staged_directory(out, last=("index.html", "obstacles.json")) as stage:
        for name in ("index.html", "obstacles.json", "a.png", "z.png"):
            (stage / name).write_text(name)
    assert moved == ["a.png", "z.png", "index.html", "obstacles.json"]
