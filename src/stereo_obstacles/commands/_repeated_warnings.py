"""Each warning once over a run of many pairs (video frames, evaluated scenes)."""

from __future__ import annotations

import contextlib
import logging
from collections.abc import Callable, Iterator


class _OncePerMessage:
    """A logging filter that lets each warning through once: the same condition (a varied
    reference area, a cut-off disparity range) would otherwise be logged for every pair.
    Warnings are told apart by their format string, so changing numbers do not repeat them;
    other levels (info, errors) pass."""

    def __init__(self) -> None:
        self.seen: set[tuple[str, str]] = set()
        self.repeats = 0

    def filter(self, record) -> bool:
        if record.levelno != logging.WARNING:
            return True
        key = (record.name, str(record.msg))
        if key in self.seen:
            self.repeats += 1
            return False
        self.seen.add(key)
        return True


@contextlib.contextmanager
def each_warning_once(enabled: bool = True) -> Iterator[Callable[[], int]]:
    """Within the block, each warning reaches the root logger's handlers once (``enabled``: the
    CLI passes ``not --verbose``). Yields a function giving how many repeats were held back."""
    pairs = [(handler, _OncePerMessage()) for handler in (logging.getLogger().handlers if enabled else ())]
    for handler, once in pairs:           # one filter per handler: each handler sees every record
        handler.addFilter(once)
    try:
        yield lambda: max((once.repeats for _, once in pairs), default=0)
    finally:
        for handler, once in pairs:
            handler.removeFilter(once)


def repeats_note(repeats: int) -> str:
    """``"N repeats of the warnings above not shown"``, or ``""`` when there were none."""
    return f"{repeats} repeats of the warnings above not shown" if repeats else ""
