"""Compiled region statistics of :mod:`stereo_obstacles.repeated_texture` (private)."""

from __future__ import annotations

import numpy as np
from numba import njit

from stereo_obstacles._similarity_kernel import CACHE


@njit(cache=CACHE, nogil=True)
def region_stats_kernel(labels, disparity, count, max_gap):
    """One pass over a labelled disparity map.

    ``labels``: ``int32 (H, W)``, region numbers ``0 .. count - 1``, -1 where unmatched;
    ``disparity``: float ``(H, W)``, pixels. Returns ``sizes`` (``int64 (count,)``, pixels per
    region), ``boxes`` (``int64 (count, 4)``: first row, first column, last row + 1, last
    column + 1) and ``mean_step`` (``float64 (count,)``: over the times a pixel of the region
    faces a match of another region along its row or column, across at most ``max_gap - 1``
    unmatched pixels, the mean of its disparity minus that match's; NaN where it faces none).
    """
    h, w = labels.shape
    sizes = np.zeros(count, np.int64)
    boxes = np.empty((count, 4), np.int64)
    boxes[:, 0] = h
    boxes[:, 1] = w
    boxes[:, 2] = 0
    boxes[:, 3] = 0
    step_sum = np.zeros(count, np.float64)
    faced = np.zeros(count, np.int64)
    for y in range(h):
        for x in range(w):
            a = labels[y, x]
            if a < 0:
                continue
            sizes[a] += 1
            boxes[a, 0] = min(boxes[a, 0], y)
            boxes[a, 1] = min(boxes[a, 1], x)
            boxes[a, 2] = max(boxes[a, 2], y + 1)
            boxes[a, 3] = max(boxes[a, 3], x + 1)
            for dy, dx in ((0, 1), (1, 0)):          # each pair once: the other side faces back
                for k in range(1, max_gap + 1):
                    ny, nx = y + k * dy, x + k * dx
                    if ny >= h or nx >= w:
                        break
                    b = labels[ny, nx]
                    if b < 0:
                        continue
                    if b != a:
                        step = np.float64(disparity[y, x]) - np.float64(disparity[ny, nx])
                        step_sum[a] += step
                        faced[a] += 1
                        step_sum[b] -= step
                        faced[b] += 1
                    break
    mean_step = np.full(count, np.nan)
    for a in range(count):
        if faced[a] > 0:
            mean_step[a] = step_sum[a] / faced[a]
    return sizes, boxes, mean_step
