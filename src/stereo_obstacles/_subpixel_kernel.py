"""Compiled parabola vertex of :mod:`stereo_obstacles.subpixel` (private)."""

from __future__ import annotations

import numpy as np
from numba import njit

from stereo_obstacles._similarity_kernel import CACHE


@njit(cache=CACHE, nogil=True)
def _parabola_offsets(c_minus, c0, c_plus):
    """float32 offsets of 1-D float64 arrays (no fast-math: the IEEE operations of the formula)."""
    out = np.zeros(c0.shape[0], np.float32)
    for i in range(c0.shape[0]):
        curvature = c_minus[i] - 2.0 * c0[i] + c_plus[i]
        if curvature < 0.0:  # false for NaN
            offset = 0.5 * (c_minus[i] - c_plus[i]) / curvature
            out[i] = min(max(offset, -0.5), 0.5) + 0.0  # + 0.0: a -0.0 becomes 0.0
    return out
