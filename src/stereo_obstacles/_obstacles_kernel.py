"""Compiled medians and quantiles of an obstacle's pixels: by patch and patch neighbourhood, or by
any integer key (private).

The public wrappers are :func:`stereo_obstacles.near_face.near_face_depth` and, for the column
medians and quantiles of a footprint, :mod:`stereo_obstacles.footprints`. The kernels share one
file so that numba's cache, kept per file, never keeps a caller compiled against an old
:func:`_by_bucket` or :func:`bucket_medians_kernel`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from stereo_obstacles._similarity_kernel import CACHE


@njit(cache=CACHE, nogil=True)
def _by_bucket(keys, values, n_buckets):
    """``values`` ordered by bucket (one counting sort), and int64 ``(n_buckets + 1,)`` where each
    bucket starts in that order (bucket ``b`` holds ``[start[b], start[b + 1])``)."""
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
    return ordered, start


@njit(cache=CACHE, nogil=True)
def bucket_medians_kernel(keys, values, n_buckets):
    """How many ``values`` fall in each bucket, and their median.

    ``keys`` int64 ``(N,)`` in ``[0, n_buckets)``: each value's bucket; ``values`` float64
    ``(N,)``, finite. Returns int64 ``(n_buckets,)`` the counts and float64 ``(n_buckets,)`` the
    medians (``np.median``'s: the mean of the two middle values of an even count; NaN for an empty
    bucket). One counting sort by bucket, then a selection within each.
    """
    ordered, start = _by_bucket(keys, values, n_buckets)
    counts = start[1:] - start[:-1]
    medians = np.full(n_buckets, np.nan)
    for b in range(n_buckets):
        if counts[b] > 0:
            medians[b] = np.median(ordered[start[b]:start[b + 1]])
    return counts, medians


@njit(cache=CACHE, nogil=True)
def bucket_quantiles_kernel(keys, values, n_buckets, low, high):
    """How many ``values`` fall in each bucket, and their ``low`` and ``high`` quantiles.

    ``keys`` and ``values`` as :func:`bucket_medians_kernel` takes them; ``low`` and ``high``
    floats in ``[0, 1]``. Returns int64 ``(n_buckets,)`` the counts and float64 ``(n_buckets,)``
    twice: the quantiles (``np.quantile``'s, interpolated linearly between the two values around
    them; NaN for an empty bucket).
    """
    ordered, start = _by_bucket(keys, values, n_buckets)
    counts = start[1:] - start[:-1]
    lows = np.full(n_buckets, np.nan)
    highs = np.full(n_buckets, np.nan)
    fractions = np.array([low, high])
    for b in range(n_buckets):
        if counts[b] > 0:
            lows[b], highs[b] = np.quantile(ordered[start[b]:start[b + 1]], fractions)   # one sort for both
    return counts, lows, highs


@njit(cache=CACHE, nogil=True)
def patch_medians_kernel(xs, ys, z, patch_px):
    """Median of ``z`` over the pixels ``(xs, ys)`` of each ``patch_px`` square patch holding any.

    ``xs, ys`` int64 ``(N,)`` (non-negative), ``z`` float64 ``(N,)``, finite. Returns, in patch
    order, float64 ``(number of patches,)`` each: the medians (``np.median``'s), the mean column
    and the mean row of the pixels each was taken over; and int64 ``(number of patches,)`` each:
    the number of those pixels, and the patch's column and row on the patch grid
    (``x // patch_px``, ``y // patch_px``).
    """
    n = xs.shape[0]
    columns = xs.max() // patch_px + 1
    n_patches = (ys.max() // patch_px + 1) * columns
    patch = np.empty(n, np.int64)
    sum_x = np.zeros(n_patches, np.float64)
    sum_y = np.zeros(n_patches, np.float64)
    for i in range(n):
        patch[i] = (ys[i] // patch_px) * columns + xs[i] // patch_px
        sum_x[patch[i]] += xs[i]
        sum_y[patch[i]] += ys[i]
    counts, medians = bucket_medians_kernel(patch, z, n_patches)
    held = np.nonzero(counts)[0]
    return (medians[held], sum_x[held] / counts[held], sum_y[held] / counts[held], counts[held],
            held % columns, held // columns)


@njit(cache=CACHE, nogil=True)
def neighbourhood_medians_kernel(values, columns, rows, radius):
    """Median of ``values`` over each patch's neighbourhood: the patches of the list within
    ``radius`` patches of it in column and in row, itself included.

    ``values`` float64 ``(n,)``, finite, ``n >= 1``; ``columns, rows`` int64 ``(n,)``: the patches'
    places on the patch grid (non-negative, no place twice); ``radius`` int >= 0. Returns float64
    ``(n,)``, medians as :func:`patch_medians_kernel` takes them (the mean of the two middle
    values of an even count).
    """
    n = values.shape[0]
    index = np.full((rows.max() + 1 + 2 * radius, columns.max() + 1 + 2 * radius), -1, np.int64)
    for i in range(n):
        index[rows[i] + radius, columns[i] + radius] = i
    side = 2 * radius + 1
    window = np.empty(side * side, np.float64)
    medians = np.empty(n, np.float64)
    for i in range(n):
        count = 0
        for dy in range(side):
            for dx in range(side):
                j = index[rows[i] + dy, columns[i] + dx]
                if j >= 0:
                    window[count] = values[j]
                    count += 1
        medians[i] = np.median(window[:count])
    return medians
