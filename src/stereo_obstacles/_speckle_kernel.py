"""Compiled region labelling of :mod:`stereo_obstacles.speckles` (private)."""

from __future__ import annotations

import numpy as np
from numba import njit

from stereo_obstacles._similarity_kernel import CACHE


@njit(cache=CACHE, nogil=True)
def speckle_kernel(disparity, max_size, max_difference, removed):
    """Set ``removed`` (``bool (H, W)``, all False on entry) on the regions of at most ``max_size``
    pixels; a region is 4-connected through neighbours whose finite disparities differ by at most
    ``max_difference`` (float64; the steps are computed in float64). Breadth-first flood fill, every
    pixel entered once; returns the count set."""
    h, w = disparity.shape
    seen = np.zeros((h, w), np.bool_)
    queue_y = np.empty(h * w, np.int32)
    queue_x = np.empty(h * w, np.int32)
    n_removed = 0
    for y0 in range(h):
        for x0 in range(w):
            if seen[y0, x0] or not np.isfinite(disparity[y0, x0]):
                continue
            seen[y0, x0] = True
            queue_y[0], queue_x[0] = y0, x0
            head, tail = 0, 1
            while head < tail:
                y, x = queue_y[head], queue_x[head]
                head += 1
                d = disparity[y, x]
                for k in range(4):
                    ny = y + (k == 1) - (k == 0)
                    nx = x + (k == 3) - (k == 2)
                    if 0 <= ny < h and 0 <= nx < w and not seen[ny, nx]:
                        e = disparity[ny, nx]
                        if np.isfinite(e) and abs(np.float64(e) - np.float64(d)) <= max_difference:
                            seen[ny, nx] = True
                            queue_y[tail], queue_x[tail] = ny, nx
                            tail += 1
            if tail <= max_size:
                for i in range(tail):
                    removed[queue_y[i], queue_x[i]] = True
                n_removed += tail
    return n_removed
