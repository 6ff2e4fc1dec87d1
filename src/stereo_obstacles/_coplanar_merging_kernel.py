"""Compiled plane-fit sums of each group's pixels and the pairs of neighbouring groups (private).

The public wrapper is :func:`stereo_obstacles.coplanar_merging.merge_coplanar_groups`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from stereo_obstacles._similarity_kernel import CACHE

MAX_GROUPS_PER_CELL = 8
"""Distinct groups remembered per grid cell; further ones are not seen as neighbours there (a cell
of an 8 x 8 grid holds one group, or a few depth layers of one)."""


@njit(cache=CACHE, nogil=True)
def group_sums_kernel(groups, disparity, cell, n_groups, reach):
    """Sums of 1, x, y, d, x x, x y, y y, x d, y d and d d over each group's pixels, and the pairs of
    groups with pixels in one grid cell or in two neighbouring ones (8-neighbourhood), and those
    with pixels in cells farther apart, up to ``reach`` cells along each axis.

    ``groups`` int64 ``(H, W)`` with labels ``0..n_groups-1`` or -1 (none); ``disparity``
    float32 ``(H, W)``; cells of ``cell x cell`` pixels; ``reach`` >= 1. Returns the sums, float64
    ``(n_groups, 10)``, and the two sets of pairs as int64 keys ``g * n_groups + k`` with ``g < k``,
    each once, sorted (a pair of the first set may be in the second too).
    """
    h, w = groups.shape
    gh, gw = (h + cell - 1) // cell, (w + cell - 1) // cell
    sums = np.zeros((n_groups, 10))
    in_cell = np.full((gh, gw, MAX_GROUPS_PER_CELL), -1, np.int64)
    n_in_cell = np.zeros((gh, gw), np.int64)
    for y in range(h):
        for x in range(w):
            g = groups[y, x]
            if g < 0:
                continue
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
            cy, cx = y // cell, x // cell
            known = False
            for i in range(n_in_cell[cy, cx]):
                known = known or in_cell[cy, cx, i] == g
            if not known and n_in_cell[cy, cx] < MAX_GROUPS_PER_CELL:
                in_cell[cy, cx, n_in_cell[cy, cx]] = g
                n_in_cell[cy, cx] += 1
    # each unordered pair of cells once: the cell itself, those to its right, and those below
    n_near, n_far = 0, 0
    near = np.empty(0, np.int64)
    far = np.empty(0, np.int64)
    for fill in range(2):
        if fill == 1:
            near, far = np.empty(n_near, np.int64), np.empty(n_far, np.int64)
            n_near, n_far = 0, 0
        for cy in range(gh):
            for cx in range(gw):
                for oy in range(reach + 1):
                    for ox in range(-reach, reach + 1):
                        ny, nx = cy + oy, cx + ox
                        if (oy == 0 and ox < 0) or ny >= gh or nx < 0 or nx >= gw:
                            continue
                        for i in range(n_in_cell[cy, cx]):
                            for j in range(n_in_cell[ny, nx]):
                                a, b = in_cell[cy, cx, i], in_cell[ny, nx, j]
                                if a == b:
                                    continue
                                if max(oy, abs(ox)) <= 1:
                                    if fill == 1:
                                        near[n_near] = min(a, b) * n_groups + max(a, b)
                                    n_near += 1
                                else:
                                    if fill == 1:
                                        far[n_far] = min(a, b) * n_groups + max(a, b)
                                    n_far += 1
    return sums, np.unique(near), np.unique(far)
