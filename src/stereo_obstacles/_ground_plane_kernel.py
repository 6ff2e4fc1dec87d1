"""Compiled inlier counting of RANSAC plane candidates (private).

The public wrapper is :func:`stereo_obstacles.ground_plane.fit_plane_points`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from stereo_obstacles._similarity_kernel import CACHE


@njit(cache=CACHE, nogil=True)
def _count_inliers(planes, x, y, d, threshold):
    """Points within ``threshold`` of each plane: ``|a x + b y + c - d| <= threshold``.

    ``planes`` is ``(K, 3)`` rows ``(a, b, c)``; ``x, y, d`` are ``(N,)`` float64. Returns
    ``(K,)`` int64 counts.
    """
    counts = np.zeros(planes.shape[0], np.int64)
    for k in range(planes.shape[0]):
        a = planes[k, 0]
        b = planes[k, 1]
        c = planes[k, 2]
        n = 0
        for i in range(x.shape[0]):
            if abs(a * x[i] + b * y[i] + c - d[i]) <= threshold:
                n += 1
        counts[k] = n
    return counts
