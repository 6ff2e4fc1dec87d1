"""Compiled test of which raised matches would be ground the right camera cannot see (private).

The public wrapper is :func:`stereo_obstacles.hidden_ground.hidden_ground`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from stereo_obstacles._similarity_kernel import CACHE
from stereo_obstacles._visibility_kernel import _matched, right_image_cover


@njit(cache=CACHE, nogil=True)
def hidden_ground_kernel(disparity, mask, a, b, c, min_jump_px, max_edge_gap_px, surface_gap_px,
                         surface_tolerance_px):
    """bool ``(H, W)``: the ``mask`` matches left of an occluding edge whose ground, at the plane
    ``a x + b y + c`` (pixels of disparity), the right camera would see covered by a surface more
    than ``min_jump_px`` nearer than the match (see :func:`stereo_obstacles.hidden_ground.hidden_ground`).

    ``disparity`` float32 ``(H, W)``, unmatched where not finite or above ``2 W``; ``mask`` bool
    ``(H, W)``. An occluding edge lies between two neighbouring matches of a row at most
    ``max_edge_gap_px`` columns apart whose disparity rises by more than ``min_jump_px`` from left
    to right; the
    right-image cover is built as the visibility test builds it (``surface_gap_px``,
    ``surface_tolerance_px``).
    """
    h, w = disparity.shape
    hidden = np.zeros((h, w), np.bool_)
    cover = np.empty(w, np.float64)  # nearest disparity seen at each right-image column
    for y in range(h):
        if not mask[y].any():  # the tested matches are few (raised ground-coloured pixels)
            continue
        covered = False  # the row's cover, built when first needed
        previous = -1
        for near in range(w):
            d_near = np.float64(disparity[y, near])
            if not _matched(d_near, w):
                continue
            far = previous
            previous = near
            if far < 0 or near - far > max_edge_gap_px or d_near - np.float64(disparity[y, far]) <= min_jump_px:
                continue
            # an edge: ground at x, seen by the right camera at x - plane, lies behind the near side
            # when x - plane >= near - d_near - 0.5; with plane > 0 that is never beyond d_near + 0.5 columns
            x = far
            while x >= 0 and near - x <= d_near + 0.5:
                if mask[y, x] and _matched(disparity[y, x], w):
                    plane = a * x + b * y + c
                    if plane > 0.0 and near - x <= d_near - plane + 0.5:
                        if not covered:
                            right_image_cover(disparity[y], cover, surface_gap_px, surface_tolerance_px)
                            covered = True
                        r = math.floor(x - plane + 0.5)
                        if 0 <= r < w and cover[r] > np.float64(disparity[y, x]) + min_jump_px:
                            hidden[y, x] = True
                x -= 1
    return hidden
