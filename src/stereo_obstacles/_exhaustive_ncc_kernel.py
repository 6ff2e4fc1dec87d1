"""Compiled core of the exhaustive NCC winner-takes-all matcher (see :mod:`stereo_obstacles.peers`).

The public wrapper :func:`stereo_obstacles.peers.ncc_wta_disparity` validates the images,
converts them to ``float64`` grey and precomputes the window means and standard deviations,
so this kernel only loops over disparities, rows and columns.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _ncc_wta_kernel(left, right, mean_l, std_l, mean_r, std_r, radius, d_min, d_max, min_std):
    """Best NCC disparity of every left pixel over ``d_min..d_max``, with a parabola fit.

    Parameters
    ----------
    left, right : float64 (H, W)
        Grey images.
    mean_l, std_l, mean_r, std_r : float64 (H, W)
        Mean and standard deviation of the ``(2 radius + 1)^2`` window centred on each pixel.
    radius, d_min, d_max : int
        Window radius and the inclusive disparity range (``0 <= d_min <= d_max``).
    min_std : float
        Windows with a smaller standard deviation (textureless) are not compared.

    Returns
    -------
    disparity : float32 (H, W)
        Best disparity refined by a parabola through the scores at ``d - 1, d, d + 1``
        (integer where a neighbour score is missing); NaN where no window could be compared.
    score : float32 (H, W)
        NCC of the best integer disparity, NaN where unmatched.
    """
    h, w = left.shape
    n = (2 * radius + 1) * (2 * radius + 1)
    best = np.full((h, w), -np.inf)
    best_d = np.full((h, w), -1, dtype=np.int64)
    before = np.full((h, w), np.nan)
    after = np.full((h, w), np.nan)
    last = np.full((h, w), np.nan)
    colsum = np.zeros(w)
    for d in range(d_min, d_max + 1):
        x_first = max(radius, d + radius)
        for y in range(radius, h - radius):
            for x in range(d, w):
                s = 0.0
                for yy in range(y - radius, y + radius + 1):
                    s += left[yy, x] * right[yy, x - d]
                colsum[x] = s
            for x in range(radius, w - radius):
                if x < x_first:
                    last[y, x] = np.nan
                    continue
                if std_l[y, x] < min_std or std_r[y, x - d] < min_std:
                    last[y, x] = np.nan
                    continue
                s = 0.0
                for xx in range(x - radius, x + radius + 1):
                    s += colsum[xx]
                c = (s / n - mean_l[y, x] * mean_r[y, x - d]) / (std_l[y, x] * std_r[y, x - d])
                if c > best[y, x]:
                    best[y, x] = c
                    best_d[y, x] = d
                    before[y, x] = last[y, x]
                    after[y, x] = np.nan
                elif d == best_d[y, x] + 1:
                    after[y, x] = c
                last[y, x] = c
    disparity = np.full((h, w), np.nan, dtype=np.float32)
    score = np.full((h, w), np.nan, dtype=np.float32)
    for y in range(h):
        for x in range(w):
            if best_d[y, x] < 0:
                continue
            offset = 0.0
            cm = before[y, x]
            cp = after[y, x]
            if not (np.isnan(cm) or np.isnan(cp)):
                denom = cm + cp - 2.0 * best[y, x]
                if denom < 0.0:
                    offset = 0.5 * (cm - cp) / denom
            disparity[y, x] = best_d[y, x] + offset
            score[y, x] = best[y, x]
    return disparity, score
