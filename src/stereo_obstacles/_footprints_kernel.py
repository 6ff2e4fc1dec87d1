"""Compiled gaps between the spans of two footprints, :func:`stereo_obstacles.footprints.close_spans`
(private).

A span is a segment on the ground plan; two obstacles' spans are compared every one with every
other (hundreds each on a large obstacle of a 1242-pixel-wide frame), which took NumPy's
broadcasting 74 ms on KITTI 000005 against about 1 ms here.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from stereo_obstacles._similarity_kernel import CACHE


@njit(cache=CACHE, nogil=True)
def _to_segment(px, pz, x0, z0, x1, z1):
    """Distance from the point ``(px, pz)`` to the segment from ``(x0, z0)`` to ``(x1, z1)``."""
    dx, dz = x1 - x0, z1 - z0
    length2 = dx * dx + dz * dz
    reach = 0.0
    if length2 > 0.0:
        reach = min(1.0, max(0.0, ((px - x0) * dx + (pz - z0) * dz) / length2))
    return math.hypot(px - (x0 + reach * dx), pz - (z0 + reach * dz))


@njit(cache=CACHE, nogil=True)
def _side(px, pz, x0, z0, x1, z1):
    """Which side of the line through ``(x0, z0)`` and ``(x1, z1)`` the point ``(px, pz)`` lies
    on: 1 or -1 by the sign of the cross product, 0 on the line, or so near it that the sign is
    rounding (within ``1e-12`` of the two products' size: two spans of one image column lie on one
    line of sight, where rounding gave apart spans opposite signs and a gap of 0)."""
    along, across = (x1 - x0) * (pz - z0), (z1 - z0) * (px - x0)
    slack = 1e-12 * (abs(along) + abs(across))
    if along - across > slack:
        return 1
    if along - across < -slack:
        return -1
    return 0


@njit(cache=CACHE, nogil=True)
def segment_gap(a, b):
    """Least distance between the segments ``a`` and ``b`` (float64 ``(4,)`` each: ``x0, z0, x1,
    z1``): 0 where they cross, else the least distance from an end of one to the other."""
    if (_side(a[0], a[1], b[0], b[1], b[2], b[3]) * _side(a[2], a[3], b[0], b[1], b[2], b[3]) < 0
            and _side(b[0], b[1], a[0], a[1], a[2], a[3]) * _side(b[2], b[3], a[0], a[1], a[2], a[3]) < 0):
        return 0.0
    return min(_to_segment(a[0], a[1], b[0], b[1], b[2], b[3]), _to_segment(a[2], a[3], b[0], b[1], b[2], b[3]),
               _to_segment(b[0], b[1], a[0], a[1], a[2], a[3]), _to_segment(b[2], b[3], a[0], a[1], a[2], a[3]))


@njit(cache=CACHE, nogil=True)
def close_spans_kernel(first, second, max_gap):
    """How many rows of each of ``first`` and ``second`` (float64 ``(n, 4)`` and ``(m, 4)``,
    segments as :func:`segment_gap` takes them) lie within ``max_gap`` of a row of the other."""
    near_first = np.zeros(first.shape[0], np.bool_)
    near_second = np.zeros(second.shape[0], np.bool_)
    for i in range(first.shape[0]):
        a = first[i]
        for j in range(second.shape[0]):
            if near_first[i] and near_second[j]:
                continue
            b = second[j]
            # segments whose boxes lie farther apart than the gap in X or in Z cannot touch
            if (max(min(a[0], a[2]), min(b[0], b[2])) - min(max(a[0], a[2]), max(b[0], b[2])) > max_gap
                    or max(min(a[1], a[3]), min(b[1], b[3])) - min(max(a[1], a[3]), max(b[1], b[3])) > max_gap):
                continue
            if segment_gap(a, b) <= max_gap:
                near_first[i] = True
                near_second[j] = True
    return int(near_first.sum()), int(near_second.sum())
