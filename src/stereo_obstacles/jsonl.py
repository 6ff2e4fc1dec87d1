"""JSON lines written one complete line at a time, so that a killed run leaves only whole lines.

Each record is encoded first, then handed to the operating system in a single ``write`` of
the whole line (newline included; a short write is continued) and, in a regular file, made
durable with ``fsync`` before the next record is encoded (a named pipe another process reads,
or ``/dev/null``, is written the same way, without the ``fsync``). A run stopped by Ctrl-C (``KeyboardInterrupt``
is raised between Python statements, never inside the ``write``) or killed by a signal
therefore leaves a file whose every line is a complete JSON document; only a crash of the
machine or a full disk in the middle of a line can leave a torn last line, which
:func:`read_json_lines` reports.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from stereo_obstacles.atomic import is_pipe_or_device, prepare_parent
from stereo_obstacles.errors import InputFileError, OutputError

__all__ = ["JsonLinesWriter", "read_json_lines"]


class JsonLinesWriter:
    """Append JSON records to a new file (an existing file is replaced), one durable line each.

    Use as a context manager; :meth:`write` adds one record.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "frames.jsonl"
    >>> with JsonLinesWriter(path) as out:
    ...     out.write({"frame": 0}); out.write({"frame": 1})
    >>> read_json_lines(path)
    [{'frame': 0}, {'frame': 1}]
    """

    def __init__(self, path: str | os.PathLike[str], *, sync: bool = True) -> None:
        self.path = Path(path)
        if not is_pipe_or_device(self.path):
            prepare_parent(self.path)
        try:
            self._fd: int | None = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o666)
            # a pipe another process reads (or /dev/null) has nothing to make durable: fsync fails there
            self.sync = sync and not is_pipe_or_device(self.path)
        except OSError as exc:
            raise OutputError(f"cannot write {self.path}: {exc.strerror or exc}") from exc
        self.lines = 0

    def write(self, record: dict) -> None:
        """Write ``record`` as one line (``allow_nan=False``: NaN must be ``None`` already)."""
        if self._fd is None:
            raise OutputError(f"{self.path} is closed")
        data = (json.dumps(record, allow_nan=False, separators=(",", ":")) + "\n").encode("utf-8")
        view = memoryview(data)
        try:
            while view:
                written = os.write(self._fd, view)
                view = view[written:]
            if self.sync:
                os.fsync(self._fd)
        except OSError as exc:
            raise OutputError(f"cannot write {self.path}: {exc.strerror or exc}") from exc
        self.lines += 1

    def close(self) -> None:
        """Close the file (safe to call twice)."""
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None

    def __enter__(self) -> JsonLinesWriter:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def read_json_lines(path: str | os.PathLike[str]) -> list[dict]:
    """Every record of a JSON-lines file.

    Raises
    ------
    InputFileError
        The file is missing, or a line is not complete JSON (the line number is named).
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise InputFileError(f"cannot read {p}: {exc.strerror or exc}") from exc
    records = []
    for number, line in enumerate(text.splitlines(keepends=True), start=1):
        if not line.endswith("\n"):
            raise InputFileError(f"{p}: line {number} is incomplete (no newline)")
        try:
            records.append(json.loads(line))
        except json.JSONDecodeError as exc:
            raise InputFileError(f"{p}: line {number} is not valid JSON: {exc.msg}") from exc
    return records
