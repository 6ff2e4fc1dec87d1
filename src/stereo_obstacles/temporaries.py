"""Hidden temporaries beside an output, held by their writer while it runs.

An output is written to a hidden temporary beside it (a file ``.NAME.@xxxxxxxx.part.EXT``, or a
staging folder ``.NAME.@xxxxxxxx.partial``) and renamed into place when whole
(:mod:`stereo_obstacles.atomic`). A run killed outright (SIGKILL, the out-of-memory killer)
cannot remove its own. So the writer holds an exclusive ``flock`` on each temporary while it
writes it, which the kernel drops when the process ends however it ends, and the next write of
the same name removes the temporaries of that name that nobody holds and that are at least
:data:`ABANDONED_AFTER_S` old.

A lock tells a live writer on this machine, in any container, from a dead one, where a process
id or a host name cannot. The age closes the moment between a temporary's creation and its
lock. Left alone: anything held, anything younger, a name without the ``@`` mark (an earlier
version's, or not ours), and everything where ``flock`` is not there (Windows) or refuses (a
network file system that cannot lock folders).
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import tempfile
import threading
import time
from pathlib import Path

try:
    import fcntl
except ImportError:                           # Windows: temporaries are neither held nor cleaned up
    fcntl = None

__all__ = ["ABANDONED_AFTER_S", "create_temporary_file", "create_temporary_folder", "release", "rename_temporary",
           "temporary_folders", "unheld"]

ABANDONED_AFTER_S = 60.0
"""A temporary nobody holds is removed only when it was last changed this many seconds ago."""

MARK = "@"
"""Put before the random part of the name of a temporary its writer holds."""

_held: dict[Path, int] = {}
"""File descriptors holding this process's locks, by temporary."""
_held_guard = threading.Lock()


def _prefix(name: str) -> str:
    return f".{name}.{MARK}"


def _hold(path: Path) -> None:
    """Lock ``path`` for as long as this process runs or until :func:`release` (best effort)."""
    if fcntl is None:
        return
    try:
        fd = os.open(path, os.O_RDONLY)              # a folder too
    except OSError:
        return
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        os.close(fd)
        return
    with _held_guard:
        _held[path] = fd


def release(path: Path) -> None:
    """Drop this process's lock on the temporary ``path`` (before it is renamed or removed)."""
    with _held_guard:
        fd = _held.pop(Path(path), None)
    if fd is not None:
        os.close(fd)


def _abandoned(entry: os.DirEntry, now: float) -> bool:
    """Whether nobody holds ``entry`` and it has not changed for :data:`ABANDONED_AFTER_S`."""
    try:
        if now - entry.stat(follow_symlinks=False).st_mtime < ABANDONED_AFTER_S:
            return False
    except OSError:
        return False
    return unheld(Path(entry.path))


def _temporaries(folder: Path, name: str, ending: str) -> list[os.DirEntry]:
    """The temporaries of ``name`` in ``folder`` whose names end in ``ending`` (none where they
    cannot be listed)."""
    prefix = _prefix(name)
    pattern = re.compile(rf"{re.escape(prefix)}[a-z0-9_]+{re.escape(ending)}", flags=re.ASCII)
    try:
        with os.scandir(folder) as entries:
            return [e for e in entries if e.name.startswith(prefix) and pattern.fullmatch(e.name)]
    except OSError:
        return []


def temporary_folders(final: Path, ending: str) -> list[Path]:
    """The temporary folders of ``final`` whose names end in ``ending`` there are now, held or
    not, of any age (real folders, not links)."""
    return [Path(e.path) for e in _temporaries(final.parent, final.name, ending) if e.is_dir(follow_symlinks=False)]


def rename_temporary(path: Path, ending: str, new_ending: str) -> Path:
    """Rename the temporary ``path`` (``.NAME.@xxxxxxxx`` plus ``ending``) to end in ``new_ending``
    instead, still held by this process when it was; ``OSError`` when it cannot be."""
    renamed = path.with_name(path.name[:-len(ending)] + new_ending)
    os.rename(path, renamed)
    with _held_guard:
        if path in _held:
            _held[renamed] = _held.pop(path)
    return renamed


def unheld(path: Path) -> bool:
    """Whether nobody holds the temporary ``path`` now, of any age (for temporaries only ever made
    held, as a staging folder renamed by :func:`rename_temporary`); ``False`` where ``flock`` is
    not there or refused: it cannot be told."""
    if fcntl is None:
        return False
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW)      # a symbolic link fails here: not ours
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:                            # held by a live writer, or locks are refused here
        return False
    finally:
        os.close(fd)
    return True


def _remove_abandoned(folder: Path, name: str, ending: str) -> None:
    """Remove the abandoned temporaries of ``name`` in ``folder`` whose names end in ``ending``.
    Errors are ignored: a leftover is untidy, not wrong."""
    if fcntl is None:
        return
    now = time.time()
    for entry in _temporaries(folder, name, ending):
        if not _abandoned(entry, now):
            continue
        if entry.is_dir(follow_symlinks=False):
            shutil.rmtree(entry.path, ignore_errors=True)
        else:
            with contextlib.suppress(OSError):
                os.unlink(entry.path)


def create_temporary_file(final: Path, ending: str) -> Path:
    """Create an empty private file ``.NAME.@xxxxxxxx`` plus ``ending`` beside ``final`` (its folder
    must exist), held until :func:`release`; abandoned ones of ``final`` are removed first.
    ``OSError`` when it cannot be created."""
    _remove_abandoned(final.parent, final.name, ending)
    fd, name = tempfile.mkstemp(prefix=_prefix(final.name), suffix=ending, dir=final.parent)
    os.close(fd)
    _hold(Path(name))
    return Path(name)


def create_temporary_folder(final: Path, ending: str = ".partial") -> Path:
    """Create a private folder ``.NAME.@xxxxxxxx`` plus ``ending`` beside ``final`` (its parent must
    exist), held until :func:`release`; abandoned ones of ``final`` are removed first. ``OSError``
    when it cannot be created."""
    _remove_abandoned(final.parent, final.name, ending)
    path = Path(tempfile.mkdtemp(prefix=_prefix(final.name), suffix=ending, dir=final.parent))
    _hold(path)
    return path
