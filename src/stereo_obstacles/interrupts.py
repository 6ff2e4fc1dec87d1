"""Ctrl-C as a request to stop between work items, so that outputs stay whole.

A ``KeyboardInterrupt`` raised at an arbitrary point may land inside a numba kernel (which
then fails with a ``SystemError`` whose cause is the interrupt) or between two writes of one
output. :class:`StopRequest` turns the first Ctrl-C into a flag that long loops check between
items (frames, pairs); a second Ctrl-C interrupts at once. :func:`is_interrupt` recognises
both forms of an immediate interrupt.
"""

from __future__ import annotations

import logging
import signal
import threading

__all__ = ["EXIT_INTERRUPTED", "EXIT_TERMINATED", "StopRequest", "TerminationDeferred", "Terminated",
           "interrupt_exit_code", "is_interrupt"]

EXIT_INTERRUPTED = 130
"""Exit code after Ctrl-C (128 + SIGINT)."""
EXIT_TERMINATED = 143
"""Exit code after SIGTERM (128 + SIGTERM)."""


class Terminated(KeyboardInterrupt):
    """Raised by the command line's SIGTERM handler: an interrupt, so that every clean-up an
    interrupt gets (staged outputs removed, streams closed) runs too; Python's default would
    exit at once."""

logger = logging.getLogger(__name__)


class StopRequest:
    """Context manager: while active, the first SIGINT sets :attr:`requested` instead of raising.

    Outside the main thread (where signal handlers cannot be installed) it does nothing and
    Ctrl-C keeps its default behaviour.

    Examples
    --------
    >>> with StopRequest() as stop:
    ...     for item in range(3):
    ...         if stop.requested:
    ...             break
    """

    def __init__(self, what: str = "the current item") -> None:
        self.what = what
        self.requested = False
        self._previous = None

    def _handle(self, signum, frame) -> None:
        if self.requested:
            raise KeyboardInterrupt
        self.requested = True
        logger.warning("stopping after %s (press Ctrl-C again to stop at once)", self.what)

    def __enter__(self) -> StopRequest:
        if threading.current_thread() is threading.main_thread():
            self._previous = signal.signal(signal.SIGINT, self._handle)
        return self

    def __exit__(self, *exc) -> None:
        if self._previous is not None:
            signal.signal(signal.SIGINT, self._previous)
            self._previous = None


class TerminationDeferred:
    """Context manager: a SIGTERM that arrives in the block is held back and delivered (to the
    handler in place before the block) when the block ends, so that a unit of work, such as a
    frame's outputs, is done whole or not begun. Outside the main thread it does nothing.

    Examples
    --------
    >>> with TerminationDeferred():
    ...     pass                     # a SIGTERM here would be delivered on leaving the block
    """

    def __init__(self) -> None:
        self._previous = None
        self._held = False

    def _hold(self, signum, frame) -> None:
        self._held = True

    def __enter__(self) -> TerminationDeferred:
        if threading.current_thread() is threading.main_thread():
            self._previous = signal.signal(signal.SIGTERM, self._hold)
        return self

    def __exit__(self, *exc) -> None:
        if self._previous is None:
            return
        signal.signal(signal.SIGTERM, self._previous)
        self._previous = None
        if self._held:
            self._held = False
            signal.raise_signal(signal.SIGTERM)


def is_interrupt(exc: BaseException) -> bool:
    """True for a ``KeyboardInterrupt``, also when a compiled kernel wrapped it in a ``SystemError``."""
    return isinstance(exc, KeyboardInterrupt) or (isinstance(exc, SystemError)
                                                  and isinstance(exc.__cause__, KeyboardInterrupt))


def interrupt_exit_code(exc: BaseException) -> int:
    """:data:`EXIT_TERMINATED` for a :class:`Terminated` (also wrapped by a kernel), else
    :data:`EXIT_INTERRUPTED`; ``exc`` is an interrupt (:func:`is_interrupt`)."""
    terminated = isinstance(exc, Terminated) or isinstance(exc.__cause__, Terminated)
    return EXIT_TERMINATED if terminated else EXIT_INTERRUPTED
