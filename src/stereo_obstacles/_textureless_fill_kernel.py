"""Compiled row runs and ground contacts of textureless regions (private).

The public wrapper is :func:`stereo_obstacles.textureless_fill.fill_textureless`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from stereo_obstacles._similarity_kernel import CACHE


@njit(cache=CACHE, nogil=True)
def empty_regions_kernel(candidates, ids, disparity, min_area):
    """``candidates`` (int32 ``(H, W)``, 0 none, 1..n) kept where a pixel has no disparity (NaN)
    and no obstacle (``ids`` 0), and where at least ``min_area`` such pixels of its set remain;
    0 elsewhere (int32 ``(H, W)``)."""
    h, w = candidates.shape
    n = 0
    for y in range(h):
        for x in range(w):
            n = max(n, candidates[y, x])
    counts = np.zeros(n + 1, np.int64)
    for y in range(h):
        for x in range(w):
            if candidates[y, x] > 0 and ids[y, x] == 0 and disparity[y, x] != disparity[y, x]:
                counts[candidates[y, x]] += 1
    regions = np.zeros((h, w), np.int32)
    for y in range(h):
        for x in range(w):
            k = candidates[y, x]
            if k > 0 and counts[k] >= min_area and ids[y, x] == 0 and disparity[y, x] != disparity[y, x]:
                regions[y, x] = k
    return regions


@njit(cache=CACHE, nogil=True)
def _bracket(ids, disparity, y, start, step, reach):
    """The first column from ``start`` along ``step`` (-1 or +1), at most ``reach`` pixels,
    holding an obstacle pixel with a disparity; -1 if none."""
    w = ids.shape[1]
    for k in range(reach):
        x = start + step * k
        if x < 0 or x >= w:
            return -1
        if ids[y, x] > 0 and disparity[y, x] == disparity[y, x]:
            return x
    return -1


@njit(cache=CACHE, nogil=True)
def bracketed_runs_kernel(regions, ids, disparity, reach):
    """Every run of one region along a row, with the obstacle pixels bracketing it.

    ``regions`` int32 ``(H, W)`` (0: none), ``ids`` int32 ``(H, W)`` obstacle ids (0: none),
    ``disparity`` float32 ``(H, W)`` (NaN: unmatched). Returns int64 ``(n, 6)`` rows ``(y, x0,
    x1, region, xl, xr)``: the run covers columns ``x0..x1`` of row ``y``; ``xl`` / ``xr`` is the
    nearest obstacle pixel with a disparity within ``reach`` pixels left of ``x0`` / right of
    ``x1`` (-1: none).
    """
    h, w = regions.shape
    n = 0
    for y in range(h):
        for x in range(w):
            if regions[y, x] > 0 and (x == 0 or regions[y, x - 1] != regions[y, x]):
                n += 1
    runs = np.empty((n, 6), np.int64)
    i = 0
    for y in range(h):
        x = 0
        while x < w:
            region = regions[y, x]
            if region == 0:
                x += 1
                continue
            x0 = x
            while x + 1 < w and regions[y, x + 1] == region:
                x += 1
            runs[i, 0], runs[i, 1], runs[i, 2], runs[i, 3] = y, x0, x, region
            runs[i, 4] = _bracket(ids, disparity, y, x0 - 1, -1, reach)
            runs[i, 5] = _bracket(ids, disparity, y, x + 1, 1, reach)
            i += 1
            x += 1
    return runs


@njit(cache=CACHE, nogil=True)
def ground_contacts_kernel(regions, n_regions, labels, ground_label, shadow_label, max_walk):
    """Where each region's columns meet the ground below it.

    ``regions`` int32 ``(H, W)`` (0: none, 1..n_regions), ``labels`` uint8 ``(H, W)``. From the
    lowest pixel of each region in each column, walk down at most ``max_walk`` rows to the first
    pixel labelled ``ground_label`` or ``shadow_label``. Returns int64 ``(m, 3)`` rows ``(region, x, y)`` of the
    contacts found, and int64 ``(n_regions + 1,)``: the columns each region spans.
    """
    h, w = regions.shape
    lowest = np.full((n_regions + 1, w), -1, np.int64)
    for y in range(h):
        for x in range(w):
            if regions[y, x] > 0:
                lowest[regions[y, x], x] = y
    columns = np.zeros(n_regions + 1, np.int64)
    contacts = np.empty(((n_regions + 1) * w, 3), np.int64)
    m = 0
    for region in range(1, n_regions + 1):
        for x in range(w):
            y = lowest[region, x]
            if y < 0:
                continue
            columns[region] += 1
            for yy in range(y + 1, min(h, y + 1 + max_walk)):
                if labels[yy, x] == ground_label or labels[yy, x] == shadow_label:
                    contacts[m, 0], contacts[m, 1], contacts[m, 2] = region, x, yy
                    m += 1
                    break
    return contacts[:m], columns
