"""Outputs are complete or absent: atomic files and staged folders."""

from __future__ import annotations

import os

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

