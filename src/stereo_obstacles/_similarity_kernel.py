"""Compiled similarity of disparity-space points and the scanline search of seeds.

Private: :mod:`stereo_obstacles.similarity` prepares the padded images and the window
statistics these kernels read, so the kernels need no bounds checks.
"""

from __future__ import annotations

import os

import numpy as np
from numba import njit

CACHE = os.environ.get("STEREO_OBSTACLES_NUMBA_CACHE", "1") != "0"
"""Cache compiled kernels on disk (set ``STEREO_OBSTACLES_NUMBA_CACHE=0`` to opt out).

Numba checks a cached kernel against its own file only: after editing a compiled helper that
kernels of other files inline (``_visibility_kernel.right_image_cover``, this file's similarity),
run with the cache off or delete the ``__pycache__`` folders, or those kernels keep the old code.
An installation writes every file anew, so it is not affected."""

FASTMATH = {"reassoc", "contract"}
"""LLVM fast-math flags of the kernels: reassociation lets the 25 window products be summed
in independent chains (and vectorised); no ``nnan``/``ninf``, NaN marks "unmatched"."""

RADIUS = 2
"""Half the window side: the window is ``(2 * RADIUS + 1)`` pixels square (5 x 5)."""

UNDEFINED = -1.0
"""Similarity given to a point where either window is too flat to correlate."""

KIND_NCC = 0
KIND_MNCC = 1


@njit(cache=CACHE, inline="always", fastmath=FASTMATH)
def _similarity(left_pad, right_pad, mean_l, norm_l, mean_r, norm_r, kind, y, x, xr):
    """Similarity of left pixel ``(x, y)`` and right pixel ``(xr, y)`` (see ``similarity.py``)."""
    nl = norm_l[y, x]
    nr = norm_r[y, xr]
    if nl <= 0.0 or nr <= 0.0:
        return UNDEFINED
    acc = 0.0  # one partial sum per window row: five short dependency chains
    side = 2 * RADIUS + 1
    for i in range(side):
        row = 0.0
        for j in range(side):
            row += np.float64(left_pad[y + i, x + j]) * np.float64(right_pad[y + i, xr + j])
        acc += row
    cov = acc * (1.0 / (side * side)) - np.float64(mean_l[y, x]) * np.float64(mean_r[y, xr])
    if kind == KIND_NCC:
        c = cov * nl * nr
    else:
        c = 2.0 * cov / (nl + nr)
    if c > 1.0:
        c = 1.0
    elif c < -1.0:
        c = -1.0
    return c


@njit(cache=CACHE, inline="always")
def _reflect101(i, n):
    """Index ``i`` mirrored into ``[0, n)`` without repeating the edge (OpenCV ``BORDER_REFLECT_101``)."""
    if n <= 1:  # one pixel (or none, which the callers refuse: no index to return)
        return 0
    while i < 0 or i >= n:
        i = -i if i < 0 else 2 * (n - 1) - i
    return i


@njit(cache=CACHE, nogil=True)
def _window_stats_kernel(grey, offset, kind, min_var):
    """The padded image and the window statistics of one grey image ``(H, W)``.

    ``centred = grey - offset`` in float64. Returns ``pad`` (float64 ``(H + 4, W + 4)``: the float32
    rounding of ``centred``, mirrored at the border as OpenCV's ``BORDER_REFLECT_101``), the window
    means (float32 ``(H, W)``) and the norms (float32: ``1 / std`` for NCC, the variance for MNCC,
    0 where the variance is below ``min_var``), both over the 5 x 5 windows of ``centred`` mirrored
    the same way. Each window sum adds five row sums of five values, in float64; the row sums of
    the last five padded rows are kept in a ring, so no full-size scratch array is touched. No
    fast-math: the values are those of the written expressions.
    """
    h, w = grey.shape
    r = RADIUS
    side = 2 * r + 1
    if h == 0 or w == 0:  # nothing to mirror (prepare_similarity refuses such images)
        return np.zeros((h + 2 * r, w + 2 * r)), np.zeros((h, w), np.float32), np.zeros((h, w), np.float32)
    hp = h + 2 * r
    wp = w + 2 * r
    col = np.empty(wp, np.int64)
    for xx in range(wp):
        col[xx] = _reflect101(xx - r, w)
    pad = np.empty((hp, wp), np.float64)
    mean32 = np.empty((h, w), np.float32)
    norm = np.empty((h, w), np.float32)
    ring_sum = np.empty((side, w), np.float64)  # row sums of the last `side` padded rows
    ring_sqr = np.empty((side, w), np.float64)
    row = np.empty(wp, np.float64)
    scale = 1.0 / (side * side)
    for yy in range(hp):
        src = _reflect101(yy - r, h)
        for xx in range(wp):
            v = np.float64(grey[src, col[xx]]) - offset
            row[xx] = v
            pad[yy, xx] = np.float64(np.float32(v))
        k = yy % side
        for x in range(w):
            s = 0.0
            q = 0.0
            for j in range(side):
                v = row[x + j]
                s += v
                q += v * v
            ring_sum[k, x] = s
            ring_sqr[k, x] = q
        y = yy - 2 * r  # the window rows y .. y + 4 (padded) are complete
        if y < 0:
            continue
        for x in range(w):
            s = 0.0
            q = 0.0
            for i in range(side):
                s += ring_sum[(y + i) % side, x]
                q += ring_sqr[(y + i) % side, x]
            m = s * scale
            var = q * scale - m * m
            mean32[y, x] = m
            if var < min_var:
                norm[y, x] = 0.0
            elif kind == KIND_NCC:
                norm[y, x] = 1.0 / np.sqrt(var)
            else:
                norm[y, x] = var
    return pad, mean32, norm


@njit(cache=CACHE, fastmath=FASTMATH, nogil=True)
def _similarity_points(left_pad, right_pad, mean_l, norm_l, mean_r, norm_r, kind, ys, xs, xrs, out):
    """Write into ``out`` (float32, ``(N,)``) the similarity of each left pixel ``(xs[k], ys[k])``
    with the right pixel ``(xrs[k], ys[k])`` (int64 arrays of length ``N``, inside the image)."""
    for k in range(ys.shape[0]):
        out[k] = _similarity(left_pad, right_pad, mean_l, norm_l, mean_r, norm_r, kind, ys[k], xs[k], xrs[k])


@njit(cache=CACHE, fastmath=FASTMATH, nogil=True)
def _scan_best(left_pad, right_pad, mean_l, norm_l, mean_r, norm_r, kind, ys, xs, d_min, d_max,
               exclusion):
    """Best and runner-up similarity of each listed left pixel along its scanline.

    The runner-up ignores disparities within ``exclusion`` of the best one (the same peak).
    Returns ``(best_d, best_c, second_c, n_evaluated)``; ``best_d`` is -1 where the
    scanline holds no admissible disparity. Serial, no ``prange`` (waking numba's pool cost more
    than the search: 25 ms against 0.5 ms on Tsukuba); the wrapper may run chunks of pixels in
    the persistent threads of :mod:`stereo_obstacles.thread_pool` instead (``nogil``).
    """
    n = ys.shape[0]
    best_d = np.full(n, -1, np.int32)
    best_c = np.full(n, UNDEFINED, np.float32)
    second_c = np.full(n, UNDEFINED, np.float32)
    n_evaluated = 0
    row = np.empty(d_max - d_min + 1, np.float64)
    for k in range(n):
        y = ys[k]
        x = xs[k]
        hi = min(d_max, x)
        if hi < d_min:
            continue
        b = -2.0
        bd = -1
        for d in range(d_min, hi + 1):
            c = _similarity(left_pad, right_pad, mean_l, norm_l, mean_r, norm_r, kind, y, x, x - d)
            row[d - d_min] = c
            if c > b:
                b = c
                bd = d
        s = UNDEFINED
        for d in range(d_min, hi + 1):
            if abs(d - bd) > exclusion and row[d - d_min] > s:
                s = row[d - d_min]
        best_d[k] = bd
        best_c[k] = b
        second_c[k] = s
        n_evaluated += hi - d_min + 1
    return best_d, best_c, second_c, n_evaluated
