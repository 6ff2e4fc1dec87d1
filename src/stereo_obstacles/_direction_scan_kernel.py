"""Compiled nearest obstacle range per sector of bearing (private).

The public wrapper is :func:`stereo_obstacles.direction_scan.direction_scan`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from stereo_obstacles._similarity_kernel import CACHE


@njit(cache=CACHE, nogil=True)
def sector_ranges_kernel(id_map, n_ids, disparity, sector_of_column, n_sectors, cx, focal, focal_baseline, doffs,
                         min_pixels, percentile):
    """Nearest obstacle range of each sector.

    ``id_map`` int32 ``(H, W)`` (0 or less: none; below ``n_ids``), ``disparity`` float32 ``(H, W)`` (NaN:
    unmatched), ``sector_of_column`` int64 ``(W,)``. A pixel's range is ``focal_baseline / (d +
    doffs) * sqrt(1 + ((x - cx) / focal)**2)``; each obstacle with at least ``min_pixels`` (>= 1)
    pixels of finite, positive ``d + doffs`` in a sector gets the ``percentile`` of their ranges there (linear
    interpolation). Returns float64 ``(n_sectors,)``: the smallest of these (NaN: none), and
    int64 ``(n_sectors,)``: the obstacle it belongs to (0: none).
    """
    h, w = id_map.shape
    start = np.zeros(n_sectors * n_ids + 1, np.int64)
    for y in range(h):
        for x in range(w):
            obstacle = id_map[y, x]
            shifted = disparity[y, x] + doffs
            if obstacle > 0 and shifted > 0.0 and math.isfinite(shifted):
                start[sector_of_column[x] * n_ids + obstacle + 1] += 1    # one bucket per (sector, obstacle)
    for b in range(n_sectors * n_ids):
        start[b + 1] += start[b]
    fill = start[:-1].copy()
    ranges = np.empty(start[-1], np.float64)
    for y in range(h):
        for x in range(w):
            obstacle = id_map[y, x]
            shifted = disparity[y, x] + doffs
            if obstacle > 0 and shifted > 0.0 and math.isfinite(shifted):
                bucket = sector_of_column[x] * n_ids + obstacle
                slope = (x - cx) / focal
                ranges[fill[bucket]] = focal_baseline / shifted * math.sqrt(1.0 + slope * slope)
                fill[bucket] += 1
    nearest = np.full(n_sectors, np.nan)
    nearest_id = np.zeros(n_sectors, np.int64)
    for b in range(n_sectors * n_ids):
        count = start[b + 1] - start[b]
        if count < min_pixels:                                 # min_pixels >= 1
            continue
        ordered = np.sort(ranges[start[b]:start[b + 1]])
        position = (count - 1) * (percentile / 100.0)
        low = int(math.floor(position))
        high = min(low + 1, count - 1)
        value = ordered[low] + (ordered[high] - ordered[low]) * (position - low)
        sector = b // n_ids
        if math.isnan(nearest[sector]) or value < nearest[sector]:
            nearest[sector] = value
            nearest_id[sector] = b % n_ids
    return nearest, nearest_id
