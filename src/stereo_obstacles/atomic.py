"""Outputs that are either complete or absent.

A file is written to a temporary name in its destination folder and renamed over the final
name only once it is whole, so an interrupted run never leaves a truncated file that looks
finished. A set of files that belong together (a scene, a detection report) is staged in a
hidden temporary folder beside the destination and moved in only when every file is written.
Those of a run killed outright while writing are removed by the next write of the same name
(:mod:`stereo_obstacles.temporaries`); one whose move into the destination was cut short is kept
with a record of the move, which tells the next run the files it left are the set's, not a
user's (:func:`moved_in_files`).
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import stat
import tempfile
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

from stereo_obstacles.errors import OutputError
from stereo_obstacles.temporaries import (create_temporary_file, create_temporary_folder, release, rename_temporary,
                                          temporary_folders, unheld)


def _current_umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _give_default_permissions(path: Path, *, folder: bool) -> None:
    """Give ``path`` the mode a plain ``open``/``mkdir`` would (temp files are private)."""
    os.chmod(path, (0o777 if folder else 0o666) & ~_current_umask())


def prepare_parent(path: Path) -> None:
    """Create the folder ``path`` will be written into; raise :class:`OutputError` if it cannot be."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"cannot create folder {path.parent}: {exc.strerror or exc}") from exc
    if not os.access(path.parent, os.W_OK):
        raise OutputError(f"cannot write to folder {path.parent}: permission denied")


def _check_creatable(folder: Path) -> None:
    """Raise :class:`OutputError` unless ``folder`` exists as a writable folder or could be created
    (its nearest existing ancestor is a folder in which a file can be created). Leaves nothing
    behind (the trial file is anonymous or removed at once)."""
    ancestor = folder
    while not ancestor.exists() and ancestor != ancestor.parent:
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise OutputError(f"cannot create folder {folder}: {ancestor} is not a folder")
    if not os.access(ancestor, os.W_OK):
        raise OutputError(f"cannot write to folder {ancestor}: permission denied")
    # the permission bits do not tell everything (root, /proc, a full quota): try once
    try:
        with tempfile.TemporaryFile(dir=ancestor):
            pass
    except OSError as exc:
        raise OutputError(f"cannot create files in folder {ancestor}: {exc.strerror or exc}") from exc


def check_output_file(path: str | os.PathLike[str], inputs: Iterable[str | os.PathLike[str] | None] = (), *,
                      input_folders: Iterable[str | os.PathLike[str]] = ()) -> None:
    """Check, before any work is done, that ``path`` can be written as a file, names none of the
    ``inputs`` (the files the run reads, or its other outputs; ``None`` entries are skipped) and
    lies in none of the ``input_folders`` (datasets, folders of frames: a file there may be read,
    or replace one that is): raise :class:`OutputError` otherwise. Leaves nothing behind."""
    target = Path(path)
    if target.is_dir():
        raise OutputError(f"{target} is a folder; expected a file name")
    for folder in input_folders:
        if Path(folder).is_dir() and Path(folder).resolve() in target.resolve().parents:
            raise OutputError(f"{target} lies in the input folder {folder}; write it elsewhere")
    if is_pipe_or_device(target):                 # written where it is: its folder (/dev) need not be writable
        if not os.access(target, os.W_OK):
            raise OutputError(f"cannot write {target}: permission denied")
    else:
        _check_creatable(target.parent)
    _refuse_inputs(target, inputs)


def is_pipe_or_device(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is an existing named pipe or character device (``/dev/null``): a stream
    written in place, not a file made beside it and renamed."""
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return False
    return stat.S_ISFIFO(mode) or stat.S_ISCHR(mode)


def _refuse_inputs(target: Path, inputs: Iterable[str | os.PathLike[str] | None]) -> None:
    """Raise :class:`OutputError` when ``target`` names one of the ``inputs`` (``None`` skipped)."""
    for source in inputs:
        if source is None:
            continue
        same = (os.path.samefile(target, source) if target.exists() and Path(source).exists()
                else target.resolve() == Path(source).resolve())
        if same:
            raise OutputError(f"{target} is also an input or another output of this run; choose another name")


def check_output_folder(path: str | os.PathLike[str], names: Iterable[str] = (),
                        inputs: Iterable[str | os.PathLike[str] | None] = ()) -> None:
    """Check, before any work is done, that the folder ``path`` can be written and that none of the
    file ``names`` to be written into it is one of the ``inputs``: raise :class:`OutputError`
    otherwise. Leaves nothing behind."""
    folder = Path(path)
    if folder.exists() and not folder.is_dir():
        raise OutputError(f"output folder {folder} exists and is not a folder")
    _check_creatable(folder)                     # once: the names share the folder
    for name in names:
        if (folder / name).is_dir():
            raise OutputError(f"{folder / name} is a folder; expected a file name")
        _refuse_inputs(folder / name, inputs)


def refuse_foreign_files(folder: str | os.PathLike[str], names: Iterable[str], *, ours: bool, what: str,
                         missing: str) -> None:
    """Raise :class:`OutputError` when ``folder`` holds files of the ``names`` a run writes but
    not a ``what`` of this tool (``ours`` false; ``missing`` says what is not there, such as
    ``"no scene.json of it"``): a run would replace a user's own files of those names. Files a
    move of a ``what`` into ``folder`` cut short put there or was replacing are not a user's
    (:func:`moved_in_files`; the writer stages it with ``kind=what``)."""
    present = [] if ours else [name for name in names if (Path(folder) / name).exists()]
    vouched = moved_in_files(folder, what) if present else set()
    theirs = [name for name in present if name not in vouched]
    if theirs:
        raise OutputError(f"{folder} holds {', '.join(theirs)} but no {what} of this tool ({missing}): a {what} "
                          f"would replace them; write it elsewhere, or delete them")


def refuse_foreign_file(path: str | os.PathLike[str], *, ours: Callable[[Path], bool], what: str) -> None:
    """Raise :class:`OutputError` when ``path`` exists but ``ours`` does not recognise it as a
    ``what`` of this tool: a file a run writes beside the one the user named (a summary, a
    sidecar, a second format of it) would replace a user's own file of that name."""
    target = Path(path)
    if (target.exists() or target.is_symlink()) and not (target.is_file() and ours(target)):
        raise OutputError(f"{target} exists and is not a {what} of this tool: it would be replaced; move it away "
                          f"or write elsewhere")


def json_object(path: str | os.PathLike[str]) -> dict:
    """The JSON object in ``path``; an empty dict when the file cannot be read as one (for
    :func:`refuse_foreign_file`'s tests of a file's fields)."""
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def remove_file_set(folder: Path, names: tuple[str, ...], *, what: str) -> None:
    """Remove the files ``names`` from ``folder`` (the first one first: the file that makes the
    set one of this tool's, so that a set half removed is no set), and ``folder`` itself when
    nothing else is left in it; anything else there stays. :class:`OutputError` naming ``what``
    when a file cannot be removed."""
    try:
        for name in names:
            path = folder / name
            if path.is_file() or path.is_symlink():
                path.unlink()
        if not any(folder.iterdir()):
            folder.rmdir()
    except OSError as exc:
        raise OutputError(f"cannot remove {what} {folder}: {exc.strerror or exc}") from exc


def temporary_beside(path: Path, *, suffix: str | None = None) -> Path:
    """Create an empty private temporary file in ``path``'s folder (created if needed).

    Its name is hidden and ends in ``.part`` plus ``suffix`` (default: ``path``'s own), so
    writers that choose the format by extension (OpenCV) still see it. For writers that
    cannot use :func:`atomic_path` because the file stays open across calls; finish with
    :func:`move_into_place`, or :func:`discard_temporary`. Temporaries of ``path`` left by
    killed runs are removed first.
    """
    prepare_parent(path)
    try:
        return create_temporary_file(path, ".part" + (path.suffix if suffix is None else suffix))
    except OSError as exc:
        raise OutputError(f"cannot write {path}: {exc.strerror or exc}") from exc


def move_into_place(tmp: Path, final: Path) -> None:
    """Give ``tmp`` the permissions a plain ``open`` would and rename it over ``final``."""
    release(tmp)
    _give_default_permissions(tmp, folder=False)
    os.replace(tmp, final)


def discard_temporary(tmp: Path) -> None:
    """Remove the temporary ``tmp`` of :func:`temporary_beside` (if it is still there)."""
    release(tmp)
    tmp.unlink(missing_ok=True)


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it to ``path`` if the block succeeds.

    On any exception the temporary file is removed and ``path`` is left as it was.
    """
    final = Path(path)
    tmp = temporary_beside(final)
    try:
        yield tmp
        move_into_place(tmp, final)
    except OSError as exc:
        discard_temporary(tmp)
        if isinstance(exc, OutputError):
            raise
        raise OutputError(f"cannot write {final}: {exc.strerror or exc}") from exc
    except BaseException:
        discard_temporary(tmp)
        raise


def write_bytes_atomic(path: str | os.PathLike[str], data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically and return the final path."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return Path(path)


def write_text_atomic(path: str | os.PathLike[str], text: str) -> Path:
    """Write UTF-8 ``text`` to ``path`` atomically and return the final path."""
    return write_bytes_atomic(path, text.encode("utf-8"))


MOVE_RECORD = ".moved-in.json"
"""Written into a staging folder just before its files are moved into their folder: the kind of
set (``report``, ``scene``, ...) and every file the move puts there or replaces, with the device,
inode, size and modification time it has (a rename keeps them). A move cut short keeps the
staging folder with it (:func:`moved_in_files`)."""

STAGING, MOVING = ".partial", ".moving"
"""The endings of a staging folder's name while its files are written, and from the moment its
record is written and its move begins."""

INSIDE = ".staging"
"""The name the staging folders of a folder take when they are made inside it."""


def _renames_into(folder: Path) -> bool:
    """Whether a file made beside ``folder`` (a temporary of its name, removed by the next write
    of it if a kill leaves it) can be renamed into it: not across mounts, a bind mount of the same
    file system included, and not when the parent cannot be written."""
    try:
        probe = create_temporary_file(folder, ".probe")
    except OSError:
        return False
    release(probe)
    moved = folder / probe.name
    try:
        os.rename(probe, moved)
    except OSError:
        with contextlib.suppress(OSError):
            os.unlink(probe)
        return False
    finally:
        with contextlib.suppress(OSError):       # an interrupt between the two: gone all the same
            os.unlink(moved)
    return True


def _real(out_dir: Path) -> Path:
    """``out_dir`` with links and ``.``/``..`` resolved: ``--out .`` inside it, ``--out R``
    beside it and a link to it name one folder."""
    return Path(os.path.realpath(out_dir))


def _staging_place(out_dir: Path) -> Path:
    """The path whose name and folder a new staging folder of ``out_dir`` takes: its real path
    (:func:`_real`), or, when a file made beside it cannot be renamed into it,
    :data:`INSIDE` in it, whatever it is called. Tried once per write."""
    real = _real(out_dir)
    if not real.is_dir() or _renames_into(real):
        return real
    return real / INSIDE


def _kept_records(out_dir: Path) -> list[Path]:
    """The staging folders of moves into ``out_dir`` that began (ending in :data:`MOVING`),
    wherever :func:`_staging_place` put them, found without writing anything."""
    real = _real(out_dir)
    return temporary_folders(real, MOVING) + temporary_folders(real / INSIDE, MOVING)


def _file_stamp(path: Path) -> list[int] | None:
    """``[device, inode, size, modification time in ns]`` of the regular file ``path`` (not
    followed through a link), ``None`` when there is none."""
    try:
        st = path.lstat()
    except OSError:
        return None
    return [st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns] if stat.S_ISREG(st.st_mode) else None


def _record_move(stage: Path, final: Path, names: list[str], removed: tuple[str, ...], kind: str | None) -> None:
    """Write :data:`MOVE_RECORD` into ``stage``: the set's ``kind``, the files ``names`` (relative
    paths in ``stage``) about to be moved into ``final``, and the files of ``final`` the move
    replaces or removes (the ``removed`` names)."""
    stamps = [[name, _file_stamp(stage / name)] for name in names]
    stamps += [[name, _file_stamp(final / name)] for name in dict.fromkeys(names + list(removed))]
    record = {"kind": kind, "files": [[name, stamp] for name, stamp in stamps if stamp is not None]}
    (stage / MOVE_RECORD).write_text(json.dumps(record), encoding="utf-8")


def _recorded_stamps(stage: Path, kind: str | None) -> set[tuple[str, tuple]]:
    """The ``(name, stamp)`` pairs of ``stage``'s :data:`MOVE_RECORD` for a set of ``kind``
    (``None``: any); none when it has no readable one (a run killed before its move began, or
    something else of that name)."""
    path = stage / MOVE_RECORD
    try:
        if not stat.S_ISREG(path.lstat().st_mode):
            return set()
        record = json.loads(path.read_text(encoding="utf-8"))
        if kind is not None and record["kind"] != kind:
            return set()
        return {(str(name), tuple(stamp)) for name, stamp in record["files"]}
    except (OSError, UnicodeDecodeError, ValueError, TypeError, KeyError, RecursionError):
        return set()


def _still_there(stage: Path, final: Path, kind: str | None = None) -> set[str]:
    """The names of the files of ``final`` that ``stage``'s :data:`MOVE_RECORD` (of a set of
    ``kind``; ``None``: any) lists and that are still those files (device, inode, size and
    modification time)."""
    return {name for name, stamp in _recorded_stamps(stage, kind)
            if (now := _file_stamp(final / name)) is not None and tuple(now) == stamp}


def _remove_spent_records(final: Path) -> None:
    """Remove the kept staging folders of moves into ``final`` cut short whose files are all
    gone or replaced (by a move that completed), and that nobody holds."""
    for stage in _kept_records(final):
        if not _still_there(stage, final) and unheld(stage):
            shutil.rmtree(stage, ignore_errors=True)


def moved_in_files(out_dir: str | os.PathLike[str], kind: str | None = None) -> set[str]:
    """The names (relative paths) of the files now in ``out_dir`` that a move of a set of ``kind``
    (``None``: any) into it by :func:`staged_directory` put there or was about to replace when it
    was cut short (killed, interrupted, a rename that failed): the same file, by device, inode,
    size and modification time, as its staging folder's :data:`MOVE_RECORD` lists. A file written
    or changed since, a user's among them, is not one of them; a run killed before its move began
    left no record."""
    final = Path(out_dir)
    vouched = set()
    for stage in _kept_records(final):
        vouched |= _still_there(stage, final, kind)
    return vouched


@contextlib.contextmanager
def staged_directory(out_dir: str | os.PathLike[str], *, last: tuple[str, ...] = (),
                     stale: tuple[str, ...] = (), kind: str | None = None) -> Iterator[Path]:
    """Yield a hidden staging folder; on success move its files into ``out_dir``.

    ``out_dir`` may exist already: files of the same names are replaced, other files are
    kept. On an exception before the move begins the staging folder is deleted and ``out_dir``
    is untouched; one during the move is described below.
    Only regular files at the top of the staging folder and in its sub-folders are moved.

    ``last`` names the files (relative paths) that vouch for the set, such as a report's
    ``index.html``: when ``out_dir`` exists their old copies are removed before anything is
    moved and the new ones are moved after every other file, so a run killed while moving
    leaves them absent rather than beside a mix of old and new files.

    ``stale`` names files of an earlier run that this one does not write (a depth map beside an
    uncalibrated report): they are removed from ``out_dir`` with the ``last`` ones.

    Before the move into an existing ``out_dir`` begins, :data:`MOVE_RECORD` names the set's
    ``kind`` and lists the files it puts there or replaces; a move cut short (interrupted,
    killed, a rename that failed) keeps the staging folder with it, which tells the next run
    which files there are this set's (:func:`moved_in_files`) until a move into ``out_dir``
    completes. Staging folders of runs killed while still writing are removed first once nobody
    holds them and they are a minute old.
    """
    final = Path(out_dir)
    check_output_folder(final)
    if not final.is_dir():                       # an existing folder's parent need not be writable
        prepare_parent(final)
    place = _staging_place(final)
    try:
        stage = create_temporary_folder(place, STAGING)
    except OSError as exc:
        raise OutputError(f"cannot write to folder {place.parent}: {exc.strerror or exc}") from exc
    moving = False
    try:
        yield stage
        _give_default_permissions(stage, folder=True)
        if not final.exists():
            os.replace(stage, final)
            _remove_spent_records(final)
            return
        names = sorted((src.relative_to(stage) for src in stage.rglob("*") if src.is_file()),
                       key=lambda name: (name.as_posix() in last, name))
        _record_move(stage, final, [name.as_posix() for name in names], last + stale, kind)
        stage = rename_temporary(stage, STAGING, MOVING)      # from here on, the record vouches
        moving = True
        for name in last + stale:
            (final / name).unlink(missing_ok=True)
        for name in names:
            dest = final / name
            dest.parent.mkdir(parents=True, exist_ok=True)
            os.replace(stage / name, dest)
        moving = False
        _remove_spent_records(final)
    except OSError as exc:
        if isinstance(exc, OutputError):
            raise
        raise OutputError(f"cannot write to {final}: {exc.strerror or exc}") from exc
    finally:
        release(stage)
        if not moving:                       # else kept, with its record of the move
            shutil.rmtree(stage, ignore_errors=True)
