"""Compiled plane-fit sums of each group's pixels and the grid cells each group occupies (private).

The public wrapper is :func:`stereo_obstacles.coplanar_merging.merge_coplanar_groups`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from stereo_obstacles._similarity_kernel import CACHE


@njit(cache=CACHE, nogil=True)
def group_sums_kernel(groups, disparity, cell, n_groups):
    """Sums of 1, x, y, d, x x, x y, y y, x d, y d and d d over each group's pixels, and the cells
    holding any of them.

    ``groups`` int64 ``(H, W)`` with labels ``0..n_groups-1`` or -1 (none); ``disparity``
    float32 ``(H, W)``. Returns the sums, float64 ``(n_groups, 10)``, and bool ``(n_groups, gh,
    gw)``, true where a group has a pixel in the ``cell x cell`` block (``gh, gw`` rounded up).
    """
    h, w = groups.shape
    sums = np.zeros((n_groups, 10))
    occupied = np.zeros((n_groups, (h + cell - 1) // cell, (w + cell - 1) // cell), np.bool_)
    for y in range(h):
        for x in range(w):
            g = groups[y, x]
            if g < 0:
                continue
            occupied[g, y // cell, x // cell] = True
            fx, fy, d = np.float64(x), np.float64(y), np.float64(disparity[y, x])
            sums[g, 0] += 1.0
            sums[g, 1] += fx
            sums[g, 2] += fy
            sums[g, 3] += d
            sums[g, 4] += fx * fx
            sums[g, 5] += fx * fy
            sums[g, 6] += fy * fy
            sums[g, 7] += fx * d
            sums[g, 8] += fy * d
            sums[g, 9] += d * d
    return sums, occupied
