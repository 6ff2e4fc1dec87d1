"""Keeping freed memory: on glibc, worker threads that allocate and free frame-sized arrays stop
faulting in fresh pages once the thresholds are set."""

from __future__ import annotations

import platform
import subprocess
import sys

import pytest

_LOOP = """
import resource, sys
from concurrent.futures import ThreadPoolExecutor
import numpy as np
if sys.argv[1] == "keep":
    from stereo_obstacles.allocator import keep_freed_memory
    assert keep_freed_memory()
else:  # glibc's default threshold, fixed (its dynamic rise makes the count vary from run to run)
    import ctypes
    assert ctypes.CDLL(None).mallopt(-3, 128 * 1024) == 1

def frame(k):  # a frame's worth of arrays, in a worker thread as detect_stream does
    arrays = [np.ones((480 + k % 3, 640)), np.ones((480, 640, 3), np.float32), np.ones((484, 644), np.float32)]
    return sum(float(a.flat[0]) for a in arrays)

with ThreadPoolExecutor(2) as pool:
    list(pool.map(frame, range(10)))              # warm up
    start = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    list(pool.map(frame, range(100)))
print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - start)
"""


def _page_faults(mode: str) -> int:
    out = subprocess.run([sys.executable, "-c", _LOOP, mode], capture_output=True, text=True, check=True)
    return int(out.stdout.strip())


@pytest.mark.skipif(platform.system() != "Linux" or platform.libc_ver()[0] != "glibc", reason="glibc's mallopt only")
def test_freed_frame_arrays_are_reused_instead_of_faulted_in_again():
    default, kept = _page_faults("default"), _page_faults("keep")
    assert default > 10000         # 100 frames of 7.4 MB in 4 kB pages: ~180 000 fresh pages
    assert kept < default / 20     # measured: ~30
