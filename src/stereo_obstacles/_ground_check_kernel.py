"""Compiled per-pixel terms of the ground-plane stereo check (private).

The public wrapper is :func:`stereo_obstacles.ground_check.off_ground_mask`.
"""

from __future__ import annotations

import math

from numba import njit

from stereo_obstacles._similarity_kernel import CACHE

TERMS = 4
"""Channels written by :func:`ground_warp_terms_kernel`: difference, its square, edge energy,
validity (1 or 0)."""


@njit(cache=CACHE, nogil=True, inline="always")
def _neighbours(i, n):
    """Indices ``(before, after)`` and the step between them for a central difference at ``i``
    of a sequence of ``n`` (one-sided at the ends; the step is 0 when ``n == 1``)."""
    before = max(i - 1, 0)
    after = min(i + 1, n - 1)
    return before, after, after - before


@njit(cache=CACHE, nogil=True)
def ground_warp_terms_kernel(left, right, a, b, c, weight_x, weight_y, terms):
    """Left minus right seen through the ground plane, and the left's edge energy.

    ``left``, ``right``: ``float32 (H, W)`` grey images. The ground plane's disparity at
    ``(x, y)`` is ``a x + b y + c``; the right image is read at ``x - d`` by linear
    interpolation along the row (a rectified pair: same row). Writes ``terms``
    ``(H, W, TERMS)``: the difference ``left - right``, its square, the edge energy
    ``weight_x gx^2 + weight_y gy^2`` with ``gx``, ``gy`` the gradient of ``left``, and 1 where
    the pixel is valid (the plane's disparity is positive and its right column lies inside the
    image), else 0 with a zero difference.
    """
    h, w = left.shape
    for y in range(h):
        up, down, dy = _neighbours(y, h)
        for x in range(w):
            before, after, dx = _neighbours(x, w)
            gx = (left[y, after] - left[y, before]) / dx if dx > 0 else 0.0
            gy = (left[down, x] - left[up, x]) / dy if dy > 0 else 0.0
            terms[y, x, 2] = weight_x * gx * gx + weight_y * gy * gy
            d = a * x + b * y + c
            xr = x - d
            if d > 0.0 and 0.0 <= xr <= w - 1:
                x0 = min(int(math.floor(xr)), w - 1)
                t = xr - x0                          # 0 when xr is the last column
                r = right[y, x0] if t == 0.0 else right[y, x0] * (1.0 - t) + right[y, x0 + 1] * t
                difference = left[y, x] - r
                terms[y, x, 0] = difference
                terms[y, x, 1] = difference * difference
                terms[y, x, 3] = 1.0
            else:
                terms[y, x, 0] = 0.0
                terms[y, x, 1] = 0.0
                terms[y, x, 3] = 0.0


@njit(cache=CACHE, nogil=True, inline="always")
def _valid_variance(means, y, x, min_valid):
    """Variance of the difference over the valid pixels of a window, from window means of the
    terms; -1 when fewer than ``min_valid`` (fraction) of the window is valid."""
    share = means[y, x, 3]
    if share < min_valid:
        return -1.0
    mean = means[y, x, 0] / share
    return means[y, x, 1] / share - mean * mean


@njit(cache=CACHE, nogil=True)
def window_variance_kernel(means, min_valid, variance):
    """``variance (H, W)`` of the difference over each window's valid pixels (-1: too few)."""
    h, w = variance.shape
    for y in range(h):
        for x in range(w):
            variance[y, x] = _valid_variance(means, y, x, min_valid)


@njit(cache=CACHE, nogil=True)
def off_ground_kernel(terms, means, min_valid, noise_level, off):
    """``off (H, W)``: the pixel is valid (``terms``), its window has at least ``min_valid``
    valid pixels, and the difference variance over them exceeds ``noise_level`` plus the
    window's edge energy. ``means`` ``(H, W, TERMS)``: window means of ``terms`` (the validity
    mean is the valid share)."""
    h, w = off.shape
    for y in range(h):
        for x in range(w):
            variance = _valid_variance(means, y, x, min_valid)
            off[y, x] = terms[y, x, 3] > 0.0 and variance >= 0.0 and variance > noise_level + means[y, x, 2]
