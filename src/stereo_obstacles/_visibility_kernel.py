"""Compiled test of which matches the right camera cannot see (private).

The public wrapper is :func:`stereo_obstacles.visibility.hidden_in_right`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from stereo_obstacles._similarity_kernel import CACHE


@njit(cache=CACHE, nogil=True, inline="always")
def _matched(d, w):
    """A disparity counts as a match when finite and at most ``2 w`` in size (larger values
    cannot be disparities of the row; they would overflow the column arithmetic)."""
    return np.isfinite(d) and abs(d) <= 2.0 * w


@njit(cache=CACHE, nogil=True, inline="always")
def _cover(cover, low, high, seen):
    """Raise ``cover`` to ``seen`` over the integer columns in ``[low, high]``."""
    w = cover.shape[0]
    for r in range(max(math.ceil(low), 0), min(math.floor(high), w - 1) + 1):
        if seen > cover[r]:
            cover[r] = seen


@njit(cache=CACHE, nogil=True, inline="always")
def right_image_cover(row, cover, max_gap_px, surface_tolerance_px):
    """Fill ``cover`` (float64 ``(W,)``) with the nearest disparity seen at each right-image
    column by the matches of one left-image ``row`` (float32 ``(W,)``), ``-inf`` where none.

    Every match covers the columns it projects to, together with the next match of its row when
    the two are at most ``max_gap_px`` columns apart and within ``surface_tolerance_px`` (one
    surface with a small hole).
    """
    w = row.shape[0]
    cover[:] = -np.inf
    previous = -1
    for x in range(w + 1):
        if x < w and not _matched(row[x], w):
            continue
        if previous >= 0:  # the previous match, alone or with this one as one surface
            dp = np.float64(row[previous])
            low = previous - dp - 0.5
            high = low + 1.0
            seen = dp
            if x < w:
                dx = np.float64(row[x])
                if x - previous <= max_gap_px and abs(dx - dp) <= surface_tolerance_px:
                    low = min(low, x - dx - 0.5)
                    high = max(high, x - dx + 0.5)
                    seen = min(seen, dx)
            _cover(cover, low, high, seen)
        previous = x


@njit(cache=CACHE, nogil=True)
def hidden_in_right_kernel(disparity, max_gap_px, surface_tolerance_px, min_depth_gap_px):
    """bool ``(H, W)``: matches whose right-image column shows a surface more than
    ``min_depth_gap_px`` nearer (see :func:`stereo_obstacles.visibility.hidden_in_right`).

    ``disparity`` float32 ``(H, W)``; non-finite values and values above ``2 W`` are unmatched.
    """
    h, w = disparity.shape
    hidden = np.zeros((h, w), np.bool_)
    cover = np.empty(w, np.float64)  # nearest disparity seen at each right-image column
    for y in range(h):
        right_image_cover(disparity[y], cover, max_gap_px, surface_tolerance_px)
        for x in range(w):
            d = np.float64(disparity[y, x])
            if _matched(d, w):
                r = math.floor(x - d + 0.5)
                if 0 <= r < w and cover[r] > d + min_depth_gap_px:
                    hidden[y, x] = True
    return hidden
