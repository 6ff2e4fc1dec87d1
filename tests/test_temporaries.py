"""Temporaries beside an output: held by their writer, removed by the next write once abandoned."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from stereo_obstacles.atomic import staged_directory, temporary_beside, write_text_atomic
from stereo_obstacles.temporaries import ABANDONED_AFTER_S, create_temporary_folder, release

pytestmark = pytest.mark.skipif(os.name != "posix", reason="temporaries are held with flock, which is POSIX")

_WRITER = textwrap.dedent("""
    import sys, time
    from pathlib import Path
    from stereo_obstacles.atomic import staged_directory, temporary_beside
    with staged_directory(sys.argv[1]) as stage:
        (stage / "obstacles.json").write_text("{}")
        temporary_beside(Path(sys.argv[1] + ".json"))
        print("staged", flush=True)
        time.sleep(120)
    """)


def _writer(out: Path) -> subprocess.Popen:
    """A process that has staged a folder for ``out`` and a file for ``out.json`` and waits."""
    process = subprocess.Popen([sys.executable, "-c", _WRITER, str(out)], stdout=subprocess.PIPE, text=True)
    assert process.stdout.readline() == "staged\n"
    return process


def _stop(process: subprocess.Popen) -> None:
    process.kill()                                   # SIGKILL: nothing of its own clean-up runs
    process.wait(timeout=60)
    process.stdout.close()


def _age(folder: Path) -> None:
    """Make every entry of ``folder`` look untouched for longer than ``ABANDONED_AFTER_S``."""
    past = time.time() - 2 * ABANDONED_AFTER_S
    for entry in folder.iterdir():
        os.utime(entry, (past, past), follow_symlinks=False)


def _names(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


def test_temporaries_of_a_killed_run_are_removed_by_the_next_write_of_the_name(tmp_path):
    out = tmp_path / "report"
    _stop(_writer(out))
    stage_left, file_left = _names(tmp_path)
    assert stage_left.startswith(".report.@") and stage_left.endswith(".partial")
    assert file_left.startswith(".report.json.@") and file_left.endswith(".part.json")
    with staged_directory(out) as stage:                   # just killed: not yet taken for abandoned
        (stage / "obstacles.json").write_text("{}")
    assert _names(tmp_path) == [stage_left, file_left, "report"]
    _age(tmp_path)
    with staged_directory(out) as stage:
        (stage / "obstacles.json").write_text("{}")
    assert _names(tmp_path) == [file_left, "report"]       # only the temporaries of the name written
    write_text_atomic(tmp_path / "report.json", "{}")
    assert _names(tmp_path) == ["report", "report.json"]


def test_a_live_writers_temporaries_are_kept_however_old(tmp_path):
    # a process id and a host name do not tell a live writer in another container from a dead one
    out = tmp_path / "report"
    writer = _writer(out)
    try:
        _age(tmp_path)
        left = _names(tmp_path)
        with staged_directory(out) as stage:
            (stage / "obstacles.json").write_text("{}")
        write_text_atomic(tmp_path / "report.json", "{}")
        assert _names(tmp_path) == sorted(left + ["report", "report.json"])
    finally:
        _stop(writer)


def test_a_temporary_this_process_holds_is_kept(tmp_path):
    first = create_temporary_folder(tmp_path / "out")
    _age(tmp_path)
    second = create_temporary_folder(tmp_path / "out")      # another thread writing the same name
    assert first.is_dir() and second.is_dir() and first != second
    release(first)
    third = create_temporary_folder(tmp_path / "out")
    assert not first.exists() and second.is_dir() and third.is_dir()
    release(second), release(third)


def test_only_unheld_temporaries_of_the_name_are_removed(tmp_path):
    name = "a.b+c"                                           # regular-expression characters in the name
    kept = [".a.b+c.abcd1234.partial",                      # an earlier version's: no mark
            ".aXb+c.@abcd1234.partial", ".a.b+cc.@abcd1234.partial", ".a.b+c.@abcd1234.part.json",
            ".a.b+c.@ABCD1234.partial"]                      # not a name this tool makes
    for entry in kept:
        (tmp_path / entry).mkdir()
    (tmp_path / "elsewhere").mkdir()
    (tmp_path / ".a.b+c.@link0000.partial").symlink_to(tmp_path / "elsewhere")
    (tmp_path / ".a.b+c.@dead0000.partial").mkdir()          # abandoned: the one to go
    (tmp_path / ".a.b+c.@dead0000.partial" / "x.png").write_text("x")
    _age(tmp_path)
    with staged_directory(tmp_path / name) as stage:
        (stage / "x.png").write_text("x")
    assert _names(tmp_path) == sorted(kept + [".a.b+c.@link0000.partial", "a.b+c", "elsewhere"])


def test_a_file_temporary_is_released_when_moved_or_discarded(tmp_path):
    from stereo_obstacles.atomic import discard_temporary, move_into_place

    for finish in (lambda tmp: move_into_place(tmp, tmp_path / "v.mp4"), discard_temporary):
        tmp = temporary_beside(tmp_path / "v.mp4")
        assert tmp.name.startswith(".v.mp4.@") and tmp.name.endswith(".part.mp4")
        finish(tmp)
        assert not tmp.exists()
    from stereo_obstacles import temporaries
    assert temporaries._held == {}                           # no lock left open
