"""Compiled two-colour clustering of a group's pixels (private).

The public wrapper is :func:`stereo_obstacles.colour_split.split_groups_by_colour`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from stereo_obstacles._similarity_kernel import CACHE


@njit(cache=CACHE, nogil=True)
def two_colours_kernel(chroma, coloured, max_sample, max_rounds):
    """2-means of the chroma of the ``coloured`` pixels, and the nearer centre of every pixel.

    ``chroma`` uint8 ``(N, 2)``, ``coloured`` bool ``(N,)``. The centres are found on at most
    ``max_sample`` evenly spaced coloured pixels, started from the two halves along their
    principal axis, in at most ``max_rounds`` rounds. Returns the centres, float64 ``(2, 2)``, and
    each pixel's cluster, int64 ``(N,)`` (1: nearer the second centre); all clusters 0 and the
    centres NaN when no pixel is coloured or the sample does not spread.
    """
    n = chroma.shape[0]
    centres = np.full((2, 2), np.nan)
    clusters = np.zeros(n, np.int64)
    index = np.flatnonzero(coloured)
    if index.shape[0] == 0:
        return centres, clusters
    step = (index.shape[0] + max_sample - 1) // max_sample
    sample = index[::step]
    m = sample.shape[0]
    points = np.empty((m, 2), np.float64)
    mean_a = 0.0
    mean_b = 0.0
    for i in range(m):
        points[i, 0] = chroma[sample[i], 0]
        points[i, 1] = chroma[sample[i], 1]
        mean_a += points[i, 0]
        mean_b += points[i, 1]
    mean_a /= m
    mean_b /= m
    saa = 0.0
    sbb = 0.0
    sab = 0.0
    for i in range(m):
        da = points[i, 0] - mean_a
        db = points[i, 1] - mean_b
        saa += da * da
        sbb += db * db
        sab += da * db
    angle = 0.5 * math.atan2(2.0 * sab, saa - sbb)
    ca, sa = math.cos(angle), math.sin(angle)
    second = np.empty(m, np.bool_)
    for i in range(m):
        second[i] = (points[i, 0] - mean_a) * ca + (points[i, 1] - mean_b) * sa > 0.0
    for _ in range(max_rounds):
        sums = np.zeros((2, 2))
        counts = np.zeros(2)
        for i in range(m):
            k = 1 if second[i] else 0
            sums[k, 0] += points[i, 0]
            sums[k, 1] += points[i, 1]
            counts[k] += 1.0
        if counts[0] == 0.0 or counts[1] == 0.0:
            centres[:, :] = np.nan
            return centres, clusters
        for k in range(2):
            centres[k, 0] = sums[k, 0] / counts[k]
            centres[k, 1] = sums[k, 1] / counts[k]
        changed = False
        for i in range(m):
            nearer = _nearer_second(points[i, 0], points[i, 1], centres)
            if nearer != second[i]:
                second[i] = nearer
                changed = True
        if not changed:
            break
    for i in range(n):
        if _nearer_second(float(chroma[i, 0]), float(chroma[i, 1]), centres):
            clusters[i] = 1
    return centres, clusters


@njit(cache=CACHE, nogil=True)
def _nearer_second(a, b, centres):
    first = (a - centres[0, 0]) ** 2 + (b - centres[0, 1]) ** 2
    second = (a - centres[1, 0]) ** 2 + (b - centres[1, 1]) ** 2
    return second < first


@njit(cache=CACHE, nogil=True)
def group_runs_kernel(groups, coloured, n_groups):
    """Each group's pixels, in one pass.

    ``groups`` int64 ``(N,)`` (the flattened group image, -1 for none, labels below
    ``n_groups``), ``coloured`` bool ``(N,)``. Returns the pixel count and the coloured pixel
    count of each group, int64 ``(n_groups,)`` each, the start of each group's run in the third,
    int64 ``(n_groups + 1,)``, and the grouped pixels' flat indices ordered by group (in image
    order within a group), int64 ``(grouped pixels,)``.
    """
    counts = np.zeros(n_groups, np.int64)
    coloured_counts = np.zeros(n_groups, np.int64)
    for i in range(groups.shape[0]):
        g = groups[i]
        if g >= 0:
            counts[g] += 1
            if coloured[i]:
                coloured_counts[g] += 1
    starts = np.zeros(n_groups + 1, np.int64)
    for g in range(n_groups):
        starts[g + 1] = starts[g] + counts[g]
    fill = starts[:-1].copy()
    pixels = np.empty(starts[n_groups], np.int64)
    for i in range(groups.shape[0]):
        g = groups[i]
        if g >= 0:
            pixels[fill[g]] = i
            fill[g] += 1
    return counts, coloured_counts, starts, pixels


@njit(cache=CACHE, nogil=True)
def one_per_block_kernel(rows, columns):
    """The first of the pixels in each square, and each pixel's square.

    ``rows``, ``columns`` int64 ``(N,)``: the square of each pixel (non-negative). Returns the
    indices of the first pixel in each square holding any, int64 ``(squares,)`` in the order of
    those pixels, and for each pixel the index into them of its square's, int64 ``(N,)``.
    """
    n = rows.shape[0]
    first = np.full((rows.max() + 1, columns.max() + 1), -1, np.int64)
    chosen = np.empty(n, np.int64)
    square_of = np.empty(n, np.int64)
    m = 0
    for i in range(n):
        if first[rows[i], columns[i]] < 0:
            first[rows[i], columns[i]] = m
            chosen[m] = i
            m += 1
        square_of[i] = first[rows[i], columns[i]]
    return chosen[:m], square_of
