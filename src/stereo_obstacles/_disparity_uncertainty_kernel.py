"""Compiled samples of the matches, for the pair's noise (private).

The public wrapper is :func:`stereo_obstacles.disparity_uncertainty.pair_noise_sigma`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from stereo_obstacles._similarity_kernel import CACHE


@njit(cache=CACHE, nogil=True)
def match_samples_kernel(left, right, disparity, row_step):
    """The matched pixels of rows ``0, row_step, 2 row_step, ...`` whose right position ``x - d``
    has both neighbours inside the image: ``left[y, x]``, the right image interpolated linearly
    there, and ``(1 - f)**2 + f**2`` for the fraction ``f`` of that position (the share of one
    pixel's noise variance the interpolation keeps). ``left, right`` float32 ``(H, W)``,
    ``disparity`` float32 ``(H, W)`` (NaN: none). Returns three float64 ``(N,)`` in raster order."""
    h, w = disparity.shape
    size = ((h + row_step - 1) // row_step) * w
    lefts, warped, kept = np.empty(size, np.float64), np.empty(size, np.float64), np.empty(size, np.float64)
    n = 0
    for y in range(0, h, row_step):
        for x in range(w):
            d = np.float64(disparity[y, x])
            if not np.isfinite(d):
                continue
            x_right = x - d
            x0 = int(np.floor(x_right))
            if x0 < 0 or x0 + 1 >= w:
                continue
            frac = x_right - x0
            lefts[n] = left[y, x]
            warped[n] = right[y, x0] * (1.0 - frac) + right[y, x0 + 1] * frac
            kept[n] = (1.0 - frac) ** 2 + frac ** 2
            n += 1
    return lefts[:n], warped[:n], kept[:n]
