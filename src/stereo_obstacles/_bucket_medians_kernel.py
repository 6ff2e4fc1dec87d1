"""Compiled medians of values grouped by a small integer key (private).

Serves the patch medians of :mod:`stereo_obstacles.near_face` (through
:func:`stereo_obstacles._obstacles_kernel.patch_medians_kernel`) and the column medians of
:func:`stereo_obstacles.footprints.footprint`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from stereo_obstacles._similarity_kernel import CACHE


@njit(cache=CACHE, nogil=True)
def bucket_medians_kernel(keys, values, n_buckets):
    """How many ``values`` fall in each bucket, and their median.

    ``keys`` int64 ``(N,)`` in ``[0, n_buckets)``: each value's bucket; ``values`` float64
    ``(N,)``, finite. Returns int64 ``(n_buckets,)`` the counts and float64 ``(n_buckets,)`` the
    medians (``np.median``'s: the mean of the two middle values of an even count; NaN for an empty
    bucket). One counting sort by bucket, then a selection within each.
    """
    n = keys.shape[0]
    start = np.zeros(n_buckets + 1, np.int64)
    for i in range(n):
        start[keys[i] + 1] += 1
    for b in range(n_buckets):
        start[b + 1] += start[b]
    fill = start[:-1].copy()
    ordered = np.empty(n, np.float64)
    for i in range(n):
        ordered[fill[keys[i]]] = values[i]
        fill[keys[i]] += 1
    counts = start[1:] - start[:-1]
    medians = np.full(n_buckets, np.nan)
    for b in range(n_buckets):
        if counts[b] > 0:
            medians[b] = np.median(ordered[start[b]:start[b + 1]])
    return counts, medians
