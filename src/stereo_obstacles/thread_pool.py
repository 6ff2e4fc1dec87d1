"""A persistent pool of worker threads for the matcher's parallel stages.

The compiled kernels release the GIL (``nogil``), so running them in threads uses both cores.
A call runs its first task on the calling thread and the others on the pool, whose threads stay
alive between calls (waking them is cheap; measured in ``docs/matching.md``).
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

__all__ = ["run_in_threads"]

_pool: ThreadPoolExecutor | None = None
_pool_size = 0


def _executor(n_workers: int) -> ThreadPoolExecutor:
    global _pool, _pool_size
    if _pool is None or _pool_size < n_workers:
        if _pool is not None:
            _pool.shutdown(wait=True)
        _pool = ThreadPoolExecutor(max_workers=n_workers, thread_name_prefix="gcs-band")
        _pool_size = n_workers
    return _pool


def run_in_threads(function, arguments: list[tuple]) -> list:
    """``[function(*a) for a in arguments]``, the first call on the calling thread and the others on
    the persistent pool (``function`` should release the GIL to gain anything).

    Examples
    --------
    >>> run_in_threads(pow, [(2, 3), (3, 2)])
    [8, 9]
    """
    if not arguments:
        return []
    pool = _executor(len(arguments) - 1) if len(arguments) > 1 else None
    futures = [pool.submit(function, *a) for a in arguments[1:]]
    return [function(*arguments[0])] + [f.result() for f in futures]
