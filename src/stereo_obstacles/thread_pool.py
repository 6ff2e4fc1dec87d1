"""A persistent pool of worker threads for parallel stages (the matcher's bands, phase 1 beside
the matcher, the colour labels beside the stereo ground check).

The compiled kernels release the GIL (``nogil``), so running them in threads uses both cores.
A call runs its first task on the calling thread and the others on the pool, whose threads stay
alive between calls (waking them is cheap; measured in ``docs/matching.md``).
"""

from __future__ import annotations

import threading
from concurrent.futures import ThreadPoolExecutor, wait

__all__ = ["run_in_threads", "run_each_in_threads"]

_pool: ThreadPoolExecutor | None = None
_pool_size = 0
_pool_lock = threading.Lock()

MIN_POOL_THREADS = 4
"""The pool has at least this many threads (started only when tasks wait for one): two callers
at once (a stream's frames in flight), each handing over a task or two (a detection hands over
its phase-1 stage and, from the matcher, a band), never wait for each other's tasks (a pool of
one thread held the second frame's band behind the first's). A task never waits for another
pool task (a call made on a pool thread runs its tasks there, one after the other), so more
callers only queue."""

_on_pool_thread = threading.local()
"""``flag`` is set on the pool's own threads."""


def _mark_pool_thread() -> None:
    _on_pool_thread.flag = True


def _submit(function, arguments: list[tuple]) -> list:
    """Futures of ``function(*a)`` on the pool, grown to at least ``len(arguments)`` threads first.

    Under a lock: a stream detects frames in several threads at once, each calling
    :func:`run_in_threads`. The pool is only ever replaced by a larger one, and the old one still
    runs the tasks it was given."""
    global _pool, _pool_size
    with _pool_lock:
        if _pool is None or _pool_size < len(arguments):
            if _pool is not None:
                _pool.shutdown(wait=False)
            _pool_size = max(len(arguments), MIN_POOL_THREADS)
            _pool = ThreadPoolExecutor(max_workers=_pool_size, thread_name_prefix="gcs-band",
                                       initializer=_mark_pool_thread)
        return [_pool.submit(function, *a) for a in arguments]


def run_in_threads(function, arguments: list[tuple]) -> list:
    """``[function(*a) for a in arguments]``, the first call on the calling thread and the others on
    the persistent pool (``function`` should release the GIL to gain anything). Called on a pool
    thread (a task that itself runs tasks), all calls run on that thread in order: a pool task
    waiting for other pool tasks could wait for ever once every pool thread does the same. When
    a call raises, the first exception in argument order propagates, after the others have
    ended (unless an interrupt arrives while waiting for them).

    Examples
    --------
    >>> run_in_threads(pow, [(2, 3), (3, 2)])
    [8, 9]
    """
    if not arguments:
        return []
    if getattr(_on_pool_thread, "flag", False):
        return [function(*a) for a in arguments]
    futures = _submit(function, arguments[1:]) if len(arguments) > 1 else []
    try:
        first = function(*arguments[0])
    finally:
        wait(futures)  # no task of this call keeps running after it has ended or failed
    return [first] + [f.result() for f in futures]


def _call(function, *arguments):
    return function(*arguments)


def run_each_in_threads(calls: list[tuple]) -> list:
    """``[f(*a) for f, *a in calls]``: :func:`run_in_threads` with a function per call.

    Examples
    --------
    >>> run_each_in_threads([(pow, 2, 3), (max, 3, 7)])
    [8, 7]
    """
    return run_in_threads(_call, calls)
