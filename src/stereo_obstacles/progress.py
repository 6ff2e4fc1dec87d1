"""A one-line progress figure on stderr for long runs: a bar for files, frames per second for cameras.

It draws only when the stream is a terminal (pipes and log files stay clean) and redraws at
most every ``interval_s`` seconds. No dependency: the whole thing is a carriage return and a line.
"""

from __future__ import annotations

import sys
import time
from typing import TextIO

__all__ = ["Progress"]


class Progress:
    """Progress of ``total`` items (``None``: unknown, e.g. a live camera).

    Parameters
    ----------
    total : int or None
        Number of items; with ``None`` only the count and the rate are shown.
    label : str
        Word for the items ("frame", "pair").
    stream : file, optional
        Where to draw (default ``sys.stderr``).
    enabled : bool, optional
        Force on or off; default: only when ``stream`` is a terminal.
    interval_s : float
        Smallest time between redraws.
    """

    def __init__(self, total: int | None, *, label: str = "frame", stream: TextIO | None = None,
                 enabled: bool | None = None, interval_s: float = 0.2) -> None:
        self.total = total
        self.label = label
        self.stream = stream if stream is not None else sys.stderr
        self.enabled = enabled if enabled is not None else bool(getattr(self.stream, "isatty", lambda: False)())
        self.interval_s = interval_s
        self.count = 0
        self._start = time.monotonic()
        self._last_draw = -float("inf")
        self._recent: list[float] = []

    def rate(self) -> float:
        """Items per second over the last (up to) 10 items."""
        if len(self._recent) < 2:
            return 0.0
        span = self._recent[-1] - self._recent[0]
        return (len(self._recent) - 1) / span if span > 0 else 0.0

    def line(self, note: str = "") -> str:
        """The text drawn for the current state."""
        rate = self.rate()
        if self.total:
            done = min(self.count, self.total)
            filled = int(20 * done / self.total)
            text = f"{self.label} {done}/{self.total} [{'#' * filled}{'.' * (20 - filled)}] {rate:.1f}/s"
            if rate > 0 and done < self.total:
                text += f" ETA {int((self.total - done) / rate)} s"
        else:
            text = f"{self.label} {self.count}  {rate:.1f} {self.label}s/s"
        return f"{text}  {note}" if note else text

    def update(self, n: int = 1, note: str = "") -> None:
        """Count ``n`` more items done and redraw if due."""
        self.count += n
        now = time.monotonic()
        self._recent = (self._recent + [now])[-10:]
        if self.enabled and (now - self._last_draw >= self.interval_s or self.count == self.total):
            self._last_draw = now
            self.stream.write("\r" + self.line(note)[:160] + "\033[K")
            self.stream.flush()

    def close(self) -> None:
        """End the line."""
        if self.enabled:
            self.stream.write("\n")
            self.stream.flush()
