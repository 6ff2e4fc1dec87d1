"""Compiled per-pixel terms of the ground-plane stereo check (private).

The public wrapper is :func:`stereo_obstacles.ground_check.off_ground_mask`.
"""

from __future__ import annotations

import math

from numba import njit

from stereo_obstacles._similarity_kernel import CACHE


@njit(cache=CACHE, nogil=True, inline="always")
def _central_difference(before, here, after, i, n):
    """Derivative at index ``i`` of ``n`` samples from its neighbours (one-sided at the ends)."""
    if n < 2:
        return 0.0
    if i == 0:
        return after - here
    if i == n - 1:
        return here - before
    return 0.5 * (after - before)


@njit(cache=CACHE, nogil=True)
def ground_warp_terms_kernel(left, right, a, b, c, weight_x, weight_y, terms, valid):
    """Left minus right seen through the ground plane, and the left's horizontal gradient.

    ``left``, ``right``: ``float32 (H, W)`` grey images. The ground plane's disparity at
    ``(x, y)`` is ``a x + b y + c``; the right image is read there by linear interpolation
    along the row (a rectified pair: same row). Writes ``terms`` ``(H, W, 3)``: the difference
    ``left - right``, its square, and the edge energy ``weight_x gx^2 + weight_y gy^2`` with
    ``gx``, ``gy`` the gradient of ``left`` (central differences, one-sided at the borders);
    and ``valid`` (the plane's disparity is positive and its right column lies inside the
    image). The difference and its square are 0 where not valid.
    """
    h, w = left.shape
    for y in range(h):
        for x in range(w):
            gx = _central_difference(left[y, max(x - 1, 0)], left[y, x], left[y, min(x + 1, w - 1)], x, w)
            gy = _central_difference(left[max(y - 1, 0), x], left[y, x], left[min(y + 1, h - 1), x], y, h)
            terms[y, x, 2] = weight_x * gx * gx + weight_y * gy * gy
            d = a * x + b * y + c
            xr = x - d
            if d > 0.0 and xr >= 0.0 and xr <= w - 1:
                x0 = min(int(math.floor(xr)), w - 2) if w > 1 else 0
                t = xr - x0
                r = right[y, x0] * (1.0 - t) + right[y, x0 + 1] * t if w > 1 else right[y, 0]
                difference = left[y, x] - r
                terms[y, x, 0] = difference
                terms[y, x, 1] = difference * difference
                valid[y, x] = True
            else:
                terms[y, x, 0] = 0.0
                terms[y, x, 1] = 0.0
                valid[y, x] = False


@njit(cache=CACHE, nogil=True)
def off_ground_kernel(sums, valid, noise_level, off):
    """``off = valid & (variance > noise_level + edge energy)`` from window means ``sums``
    ``(H, W, 3)`` of the terms written by :func:`ground_warp_terms_kernel`."""
    h, w = valid.shape
    for y in range(h):
        for x in range(w):
            mean = sums[y, x, 0]
            variance = sums[y, x, 1] - mean * mean
            off[y, x] = valid[y, x] and variance > noise_level + sums[y, x, 2]
