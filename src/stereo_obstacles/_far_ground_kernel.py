"""Compiled walk up the far rows (private; see :mod:`stereo_obstacles.far_ground`)."""

from __future__ import annotations

import numpy as np
from numba import njit

from stereo_obstacles._similarity_kernel import CACHE


@njit(cache=CACHE, nogil=True)
def far_rows_kernel(colours, off_ground, anchor, min_count, tolerance, max_step, like):
    """Mark, row by row from the last (nearest) upwards, the pixels of the row's colour.

    ``colours``: ``float32 (R, W, 3)`` log colours of the far rows, top to bottom;
    ``off_ground``: ``bool (R, W)``; ``anchor``: ``float32 (3,)``, the colour of the ground just
    under the last row. A row's colour is the per-channel median over its pixels not off the
    ground. The walk stops at a row with fewer than ``min_count`` such pixels, or whose colour
    differs from the row below (the anchor, for the last row) by more than ``max_step`` in a
    channel. In the rows walked, ``like (R, W)`` is set where every channel is within
    ``tolerance`` of the row's colour (the other rows are left as they are).
    """
    n_rows, width = off_ground.shape
    values = np.empty(width, dtype=np.float32)
    colour = np.empty(3, dtype=np.float32)
    below = anchor.copy()
    for i in range(n_rows - 1, -1, -1):
        for c in range(3):
            n = 0
            for x in range(width):
                if not off_ground[i, x]:
                    values[n] = colours[i, x, c]
                    n += 1
            if n < min_count:
                return
            colour[c] = np.median(values[:n])
            if abs(colour[c] - below[c]) > max_step:
                return
        for x in range(width):
            like[i, x] = (abs(colours[i, x, 0] - colour[0]) <= tolerance
                          and abs(colours[i, x, 1] - colour[1]) <= tolerance
                          and abs(colours[i, x, 2] - colour[2]) <= tolerance)
        below[:] = colour
