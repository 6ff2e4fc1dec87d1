"""Compiled inlier counting of RANSAC plane candidates (private).

The public wrapper is :func:`stereo_obstacles.ground_plane.fit_plane_points`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from stereo_obstacles._similarity_kernel import CACHE, FASTMATH


@njit(cache=CACHE, nogil=True, fastmath=FASTMATH)
def inlier_counts_kernel(planes, x, y, d, threshold):
    """Points within ``threshold`` of each plane (``|a x + b y + c - d| <= threshold``) and the
    sum of their squared residuals.

    ``planes`` is ``(K, 3)`` rows ``(a, b, c)``; ``x, y, d`` are ``(N,)`` float64. Returns
    ``(K,)`` int64 counts and ``(K,)`` float64 sums.
    """
    counts = np.zeros(planes.shape[0], np.int64)
    squares = np.zeros(planes.shape[0], np.float64)
    for k in range(planes.shape[0]):
        a = planes[k, 0]
        b = planes[k, 1]
        c = planes[k, 2]
        n = 0
        sq = 0.0
        for i in range(x.shape[0]):  # branch-free, so that the loop vectorises
            r = a * x[i] + b * y[i] + c - d[i]
            inside = abs(r) <= threshold
            n += inside
            sq += r * r * inside
        counts[k] = n
        squares[k] = sq
    return counts, squares


@njit(cache=CACHE, nogil=True)
def raised_pixels_kernel(disparity, mask, a, b, c, doffs, height_scale, min_height, strict, min_excess):
    """``bool`` map of the ``mask`` pixels with a finite disparity ``d`` standing above the plane.

    A pixel stands when ``d - plane >= min_excess[y, x]`` (``min_excess`` float32 ``(H, W)``)
    and, if ``height_scale`` is finite (a calibration), also ``d + doffs > 0`` and its height
    ``height_scale * (d - plane) / (d + doffs)`` is ``> min_height`` (``strict``) or
    ``>= min_height``; ``plane = a x + b y + c``.
    """
    h, w = disparity.shape
    out = np.zeros((h, w), np.bool_)
    calibrated = np.isfinite(height_scale)
    for y in range(h):
        for x in range(w):
            if not mask[y, x]:
                continue
            d = np.float64(disparity[y, x])
            if not np.isfinite(d):
                continue
            excess = d - (a * x + b * y + c)
            if excess < min_excess[y, x]:
                continue
            if calibrated:
                if d + doffs <= 0.0:
                    continue
                height = height_scale * excess / (d + doffs)
                if height < min_height or (strict and height == min_height):
                    continue
            out[y, x] = True
    return out


@njit(cache=CACHE, nogil=True)
def masked_points_kernel(disparity, mask):
    """Columns, rows and disparities (float64 ``(N,)`` each, row-major order) of the ``mask``
    pixels with a finite disparity."""
    h, w = disparity.shape
    n = 0
    for y in range(h):
        for x in range(w):
            if mask[y, x] and np.isfinite(disparity[y, x]):
                n += 1
    xs = np.empty(n, np.float64)
    ys = np.empty(n, np.float64)
    ds = np.empty(n, np.float64)
    k = 0
    for y in range(h):
        for x in range(w):
            if mask[y, x] and np.isfinite(disparity[y, x]):
                xs[k] = x
                ys[k] = y
                ds[k] = disparity[y, x]
                k += 1
    return xs, ys, ds
