"""Compiled median disparity and purity of each grid cell (private).

The public wrapper is :func:`stereo_obstacles.obstacle_grouping.group_obstacle_pixels`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from stereo_obstacles._similarity_kernel import CACHE


@njit(cache=CACHE, nogil=True)
def cell_medians_kernel(disparity, cell, min_pixels, abs_tolerance, rel_tolerance, min_pure_fraction):
    """Median of the finite values of each ``cell x cell`` block of ``disparity`` and its purity.

    ``disparity`` is float32 ``(gh * cell, gw * cell)`` with NaN for unusable pixels. A block
    with fewer than ``min_pixels`` finite values gets NaN and is not pure. Otherwise its median
    (the mean of the two middle values for an even count, as ``numpy.median``) and whether at
    least ``min_pure_fraction`` of its values lie within ``max(abs_tolerance, rel_tolerance *
    |median|)`` of it; float32 arithmetic throughout, as the NumPy definition.
    """
    gh = disparity.shape[0] // cell
    gw = disparity.shape[1] // cell
    medians = np.full((gh, gw), np.nan, np.float32)
    pure = np.zeros((gh, gw), np.bool_)
    values = np.empty(cell * cell, np.float32)
    abs_tol = np.float32(abs_tolerance)
    rel_tol = np.float32(rel_tolerance)
    for gy in range(gh):
        for gx in range(gw):
            n = 0
            for yy in range(gy * cell, gy * cell + cell):
                for xx in range(gx * cell, gx * cell + cell):
                    v = disparity[yy, xx]
                    if np.isfinite(v):
                        j = n  # insertion sort as the values arrive
                        while j > 0 and values[j - 1] > v:
                            values[j] = values[j - 1]
                            j -= 1
                        values[j] = v
                        n += 1
            if n < min_pixels:
                continue
            if n % 2 == 1:
                m = values[n // 2]
            else:
                m = (values[n // 2 - 1] + values[n // 2]) / np.float32(2.0)
            medians[gy, gx] = m
            tol = max(abs_tol, rel_tol * abs(m))
            agree = 0
            for k in range(n):
                if abs(values[k] - m) <= tol:
                    agree += 1
            pure[gy, gx] = agree >= min_pure_fraction * n
    return medians, pure


@njit(cache=CACHE, nogil=True)
def assign_pixels_kernel(disparity, usable, cell_labels, cell_disparity, cell, abs_tolerance, rel_tolerance,
                         n_labels):
    """Each usable pixel's cell label where its disparity agrees with the cell's, else -1.

    Agreement: ``|d - cell d| <= max(abs_tolerance, rel_tolerance * |cell d|)`` in float32.
    Returns the int64 ``(H, W)`` labels and the pixel count of each of the ``n_labels`` labels.
    """
    h, w = disparity.shape
    out = np.full((h, w), -1, np.int64)
    counts = np.zeros(n_labels, np.int64)
    abs_tol = np.float32(abs_tolerance)
    rel_tol = np.float32(rel_tolerance)
    for y in range(h):
        for x in range(w):
            if not usable[y, x]:
                continue
            label = cell_labels[y // cell, x // cell]
            if label < 0:
                continue
            cd = cell_disparity[y // cell, x // cell]
            if abs(disparity[y, x] - cd) <= max(abs_tol, rel_tol * abs(cd)):
                out[y, x] = label
                counts[label] += 1
    return out, counts
