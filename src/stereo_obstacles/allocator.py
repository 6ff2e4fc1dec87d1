"""Keeping freed memory for reuse in long loops over frames (glibc's ``malloc`` only).

Every frame allocates and frees the same few dozen arrays of 0.3-4 MB. glibc serves
allocations above its mmap threshold from fresh pages (``mmap``) and gives them back on
``free``, and trims its heap when its top is free: each frame then pays the page faults and
the zeroing of tens of megabytes in the kernel. Raising the thresholds keeps that memory in the
process, where the next frame reuses it (measured in ``docs/streams.md``: the ``video`` command,
180 frames at 640x480, system time 2.2 s -> 0.85-1.0 s, peak memory +25 MB; page faults of a
loop of frame-sized arrays in two threads ~38 000 -> ~30, ``tests/test_allocator.py``).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import logging

__all__ = ["MMAP_THRESHOLD_BYTES", "TOP_PAD_BYTES", "TRIM_THRESHOLD_BYTES", "keep_freed_memory"]

logger = logging.getLogger(__name__)

MMAP_THRESHOLD_BYTES = 256 << 20
"""Allocations below this come from the heap (glibc's default: 128 kB, rising with use to at
most 32 MB)."""
TRIM_THRESHOLD_BYTES = 512 << 20
"""The heap keeps up to this much free memory at its top before giving it back."""
TOP_PAD_BYTES = 64 << 20
"""Extra memory the heap takes whenever it grows."""

_M_TRIM_THRESHOLD, _M_TOP_PAD, _M_MMAP_THRESHOLD = -1, -2, -3  # mallopt parameters (malloc.h)


def keep_freed_memory() -> bool:
    """Set the thresholds above with ``mallopt``; True if the C library took them.

    Process-wide, so applications (the ``video`` command) call it, not the library. Does
    nothing, and returns False, where the C library has no ``mallopt`` (not glibc).
    """
    name = ctypes.util.find_library("c")
    try:
        mallopt = ctypes.CDLL(name).mallopt
    except (OSError, AttributeError, TypeError):
        logger.debug("no mallopt in the C library %r: allocator thresholds left as they are", name)
        return False
    mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    return all(mallopt(param, value) == 1 for param, value in ((_M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES),
                                                               (_M_TRIM_THRESHOLD, TRIM_THRESHOLD_BYTES),
                                                               (_M_TOP_PAD, TOP_PAD_BYTES)))
