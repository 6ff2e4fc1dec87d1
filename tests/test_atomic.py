"""Outputs are complete or absent: atomic files and staged folders."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from stereo_obstacles.atomic import (atomic_path, check_output_file, check_output_folder, staged_directory,
                                    write_text_atomic)
from stereo_obstacles.errors import OutputError


def test_atomic_path_replaces_only_on_success(tmp_path):
    target = tmp_path / "out.txt"
    target.write_text("old")
    with pytest.raises(RuntimeError):
        with atomic_path(target) as tmp:
            tmp.write_text("half")
            raise RuntimeError("interrupted")
    assert target.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["out.txt"]
    write_text_atomic(target, "new")
    assert target.read_text() == "new"


def test_atomic_write_creates_missing_parent_folders(tmp_path):
    write_text_atomic(tmp_path / "a" / "b" / "c.txt", "x")
    assert (tmp_path / "a" / "b" / "c.txt").read_text() == "x"


def test_staged_directory_moves_files_in_only_on_success(tmp_path):
    out = tmp_path / "scene"
    with staged_directory(out) as stage:
        (stage / "left.png").write_text("L")
        (stage / "sub").mkdir()
        (stage / "sub" / "x.txt").write_text("X")
    assert sorted(p.relative_to(out).as_posix() for p in out.rglob("*")) == ["left.png", "sub", "sub/x.txt"]
    assert [p.name for p in tmp_path.iterdir()] == ["scene"]


def test_staged_directory_failure_leaves_nothing(tmp_path):
    out = tmp_path / "scene"
    with pytest.raises(KeyboardInterrupt):
        with staged_directory(out) as stage:
            (stage / "left.png").write_text("L")
            raise KeyboardInterrupt
    assert list(tmp_path.iterdir()) == []


def test_staged_directory_into_existing_folder_keeps_other_files(tmp_path):
    out = tmp_path / "scene"
    out.mkdir()
    (out / "mine.txt").write_text("keep")
    (out / "left.png").write_text("old")
    with staged_directory(out) as stage:
        (stage / "left.png").write_text("new")
    assert (out / "mine.txt").read_text() == "keep" and (out / "left.png").read_text() == "new"


def test_outputs_get_the_usual_permissions_not_private_temp_ones(tmp_path):
    mask = os.umask(0o022)
    try:
        path = write_text_atomic(tmp_path / "report.html", "x")
        with staged_directory(tmp_path / "out") as stage:
            (stage / "a.txt").write_text("a")
    finally:
        os.umask(mask)
    assert path.stat().st_mode & 0o777 == 0o644
    assert (tmp_path / "out").stat().st_mode & 0o777 == 0o755


def test_output_path_that_is_a_file_is_refused(tmp_path):
    (tmp_path / "scene").write_text("a file")
    with pytest.raises(OutputError, match="not a folder"):
        with staged_directory(tmp_path / "scene"):
            pass


def test_output_below_a_file_is_an_output_error(tmp_path):
    (tmp_path / "file").write_text("x")
    with pytest.raises(OutputError, match="cannot create folder"):
        write_text_atomic(tmp_path / "file" / "x.txt", "x")


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="needs Linux's /proc, a folder where no file can be created")
def test_folder_without_room_for_files_is_refused_before_any_work():
    # the permission bits allow root to write anywhere; creating a file in /proc fails all the same
    # (another user is stopped by the permission bits first)
    for check in (lambda: check_output_file("/proc/x.npy"), lambda: check_output_folder("/proc/report"),
                  lambda: check_output_file("/proc/new/x.npy")):
        with pytest.raises(OutputError, match="cannot create files in folder /proc|cannot write to folder /proc"):
            check()
    with pytest.raises(OutputError, match="cannot write /proc/x.png"):
        write_text_atomic("/proc/x.png", "never written")


def test_checks_leave_nothing_behind(tmp_path):
    check_output_file(tmp_path / "a.npy")
    check_output_folder(tmp_path / "report" / "deeper")
    assert list(tmp_path.iterdir()) == []


def _killed_while_writing(out: Path) -> None:
    """Run a process that stages a folder and a file for ``out`` and kill it (SIGKILL) mid-way."""
    script = textwrap.dedent("""
        import sys, time
        from pathlib import Path
        from stereo_obstacles.atomic import staged_directory, temporary_beside
        with staged_directory(sys.argv[1]) as stage:
            (stage / "obstacles.json").write_text("{}")
            temporary_beside(Path(sys.argv[1] + ".json"))
            print("staged", flush=True)
            time.sleep(60)
        """)
    process = subprocess.Popen([sys.executable, "-c", script, str(out)], stdout=subprocess.PIPE, text=True)
    try:
        assert process.stdout.readline() == "staged\n"
    finally:
        process.kill()
        process.wait(timeout=60)
        process.stdout.close()


@pytest.mark.skipif(os.name != "posix", reason="whether a process still runs is asked with POSIX signal 0")
def test_temporaries_of_a_killed_run_are_removed_by_the_next_write_of_the_name(tmp_path):
    out = tmp_path / "report"
    _killed_while_writing(out)
    stage_left, file_left = sorted(p.name for p in tmp_path.iterdir())
    assert stage_left.startswith(".report.") and stage_left.endswith(".partial")
    assert file_left.startswith(".report.json.") and file_left.endswith(".part.json")
    host = socket.gethostname()
    dead = stage_left.split(".")[2].split("@")[0]                          # the killed process's id
    kept = [f".report.{os.getpid()}@{host}.abcd1234.partial",             # a run writing there now
            f".report.{dead}@{host}x.abcd1234.partial",                     # another host's
            ".report.abcd1234.partial",                                     # an earlier version's: no id
            ".report.json.notours.part.json", ".reportx.1.partial"]          # not a temporary of the name
    for name in kept:
        (tmp_path / name).mkdir()
    with staged_directory(out) as stage:
        (stage / "obstacles.json").write_text("{}")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(kept + [file_left, "report"])
    write_text_atomic(tmp_path / "report.json", "{}")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(kept + ["report", "report.json"])
