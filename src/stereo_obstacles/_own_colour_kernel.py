"""Compiled colour-weighted matching of :mod:`stereo_obstacles.own_colour_matching` (private)."""

from __future__ import annotations

import numpy as np
from numba import njit

from stereo_obstacles._similarity_kernel import CACHE
from stereo_obstacles._subpixel_kernel import _parabola_offsets
from stereo_obstacles._visibility_kernel import right_image_cover


@njit(cache=CACHE, nogil=True)
def own_colour_best_kernel(lab_left, lab_right, grey_left, grey_right, ys, xs, d_max, radius, colour_scale,
                           min_weight_sum, exclusion_px):
    """The disparity at which each point's window, weighted to the point's own colour, matches best.

    ``lab_*``: ``float32 (H, W, 3)`` CIE L*a*b*; ``grey_*``: ``float32 (H, W)``; ``ys``, ``xs``:
    ``int64 (n,)`` left pixels; ``d_max``: ``int64 (n,)``, the largest whole disparity tried for
    each (from 0). A window pixel ``q`` of the ``(2 radius + 1)^2`` around ``p`` weighs
    ``w_left(q) w_right(q - d)``, each ``1 / (1 + |lab(q) - lab(centre)|^2 / colour_scale^2)`` in
    its own image (the support of adaptive support weights: the pixels of the centre's colour,
    whatever lies beside them). The score is the weighted zero-mean normalised cross-correlation
    of the grey values; windows whose weights sum to less than ``min_weight_sum``, whose weighted
    variance is 1e-6 or less in either image (flat), or that leave the image, are not scored.

    Returns ``disparity`` (``float32 (n,)``: the best whole disparity moved by a parabola through
    the scores beside it, NaN when none was scored), ``score`` (``float32 (n,)``, NaN likewise) and
    ``runner_up`` (``float32 (n,)``: the best score more than ``exclusion_px`` whole disparities
    from the best, NaN when none was scored there): a ramp or a repeat scores alike at many
    disparities.
    """
    h, w = grey_left.shape
    n = ys.shape[0]
    size = 2 * radius + 1
    best_d = np.full(n, np.nan, np.float32)
    best_s = np.full(n, np.nan, np.float32)
    before = np.full(n, np.nan, np.float64)      # the scores beside the best, for its parabola
    peak = np.full(n, np.nan, np.float64)
    after = np.full(n, np.nan, np.float64)
    second_s = np.full(n, np.nan, np.float32)
    inv_scale_sq = 1.0 / (colour_scale * colour_scale)
    weight_left = np.empty((size, size), np.float64)
    for i in range(n):
        y, x = ys[i], xs[i]
        if y < radius or y >= h - radius or x < radius or x >= w - radius:
            continue
        for v in range(size):
            for u in range(size):
                dist = 0.0
                for c in range(3):
                    e = lab_left[y - radius + v, x - radius + u, c] - lab_left[y, x, c]
                    dist += e * e
                weight_left[v, u] = 1.0 / (1.0 + dist * inv_scale_sq)
        top = min(d_max[i], x - radius)
        if top < 0:
            continue
        scores = np.full(top + 1, -np.inf)
        for d in range(top + 1):
            xr = x - d
            sw = 0.0
            sa = 0.0
            sb = 0.0
            saa = 0.0
            sbb = 0.0
            sab = 0.0
            for v in range(size):
                yy = y - radius + v
                for u in range(size):
                    dist = 0.0
                    for c in range(3):
                        e = lab_right[yy, xr - radius + u, c] - lab_right[y, xr, c]
                        dist += e * e
                    wq = weight_left[v, u] / (1.0 + dist * inv_scale_sq)
                    a = grey_left[yy, x - radius + u]
                    b = grey_right[yy, xr - radius + u]
                    sw += wq
                    sa += wq * a
                    sb += wq * b
                    saa += wq * a * a
                    sbb += wq * b * b
                    sab += wq * a * b
            if sw < min_weight_sum:
                continue
            ma = sa / sw
            mb = sb / sw
            va = saa / sw - ma * ma
            vb = sbb / sw - mb * mb
            if va <= 1e-6 or vb <= 1e-6:
                continue
            scores[d] = (sab / sw - ma * mb) / np.sqrt(va * vb)
        k = np.argmax(scores)
        if scores[k] == -np.inf:
            continue
        if 0 < k < top and scores[k - 1] > -np.inf and scores[k + 1] > -np.inf:
            before[i] = scores[k - 1]
            peak[i] = scores[k]
            after[i] = scores[k + 1]
        best_d[i] = k
        best_s[i] = scores[k]
        for d in range(top + 1):
            if abs(d - k) > exclusion_px and scores[d] > -np.inf and not scores[d] <= second_s[i]:
                second_s[i] = scores[d]
    best_d += _parabola_offsets(before, peak, after)    # 0 where a neighbour was not scored
    return best_d, best_s, second_s


@njit(cache=CACHE, nogil=True)
def right_cover_rows_kernel(band, max_gap_px, surface_tolerance_px):
    """``float64 (h, W)``: for each row of ``band`` (``float32 (h, W)`` left disparities, NaN
    unmatched), the nearest disparity the right camera sees at each column, ``-inf`` where none
    (:func:`stereo_obstacles._visibility_kernel.right_image_cover`)."""
    nearest = np.empty(band.shape, np.float64)
    for y in range(band.shape[0]):
        right_image_cover(band[y], nearest[y], max_gap_px, surface_tolerance_px)
    return nearest
