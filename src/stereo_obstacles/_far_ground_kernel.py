"""Compiled walk up the far rows (private; see :mod:`stereo_obstacles.far_ground`)."""

from __future__ import annotations

import numpy as np
from numba import njit

from stereo_obstacles._similarity_kernel import CACHE


@njit(cache=CACHE, nogil=True, inline="always")
def _row_colour(colours, off_ground, row, min_count, values, colour):
    """Write into ``colour (3,)`` the per-channel median of ``colours[row]`` over the pixels not
    ``off_ground``; False (``colour`` undefined) when fewer than ``min_count`` of them."""
    width = off_ground.shape[1]
    for c in range(3):
        n = 0
        for x in range(width):
            if not off_ground[row, x]:
                values[n] = colours[row, x, c]
                n += 1
        if n < min_count:
            return False
        colour[c] = np.median(values[:n])
    return True


@njit(cache=CACHE, nogil=True)
def far_rows_kernel(colours, off_ground, min_count, tolerance, max_step, like):
    """Mark, row by row from the nearest far row upwards, the pixels of the row's colour.

    ``colours``: ``float32 (R + 1, W, 3)`` log colours of the ``R`` far rows, top to bottom,
    then of the row just under them; ``off_ground``: ``bool (R + 1, W)``. A row's colour is the
    per-channel median over its pixels not off the ground. The walk starts from the row under
    the far rows and stops at a row with fewer than ``min_count`` such pixels (nothing is
    marked when the row under them has too few), or whose colour differs from the row below by
    more than ``max_step`` in a channel. In the far rows walked, ``like (R, W)`` is set where
    every channel is within ``tolerance`` of the row's colour (the other rows are left as they
    are).
    """
    n_rows, width = like.shape
    values = np.empty(width, dtype=np.float32)
    colour = np.empty(3, dtype=np.float32)
    below = np.empty(3, dtype=np.float32)
    if not _row_colour(colours, off_ground, n_rows, min_count, values, below):
        return
    for i in range(n_rows - 1, -1, -1):
        if not _row_colour(colours, off_ground, i, min_count, values, colour):
            return
        for c in range(3):
            if abs(colour[c] - below[c]) > max_step:
                return
        for x in range(width):
            like[i, x] = (abs(colours[i, x, 0] - colour[0]) <= tolerance
                          and abs(colours[i, x, 1] - colour[1]) <= tolerance
                          and abs(colours[i, x, 2] - colour[2]) <= tolerance)
        below[:] = colour
