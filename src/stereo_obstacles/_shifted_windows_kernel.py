"""Compiled shifted-window check of final matches against foreground fattening (private).

The public wrapper is :func:`stereo_obstacles.shifted_windows.shifted_window_check`.

The 25 windows containing a pixel overlap: at one disparity they are built from the products of
a ``(4 RADIUS + 1)^2`` tile (81 products instead of 25 x 25), summed along rows then columns.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from stereo_obstacles._similarity_kernel import CACHE, FASTMATH, KIND_NCC, RADIUS, UNDEFINED

_SIDE = 2 * RADIUS + 1
_TILE = 4 * RADIUS + 1


@njit(cache=CACHE, inline="always", fastmath=FASTMATH)
def _best_shifted(lp, rp, ml, nl, mr, nr, kind, y, x, d, products, row_sums):
    """Best similarity at disparity ``d`` over the windows containing left pixel ``(x, y)``:
    the windows centred on every pixel of the ``(2 RADIUS + 1)^2`` square around it (inside the
    image, right centre inside the image); :data:`UNDEFINED` when there is none.

    Scratch (float64): ``products`` of shape ``(4 RADIUS + 1,)`` holds one row of the tile;
    ``row_sums`` of shape ``(4 RADIUS + 1, 2 RADIUS + 1)``, at row ``i`` and column ``j``, the sum
    of the products of padded row ``yc_lo + i`` over the columns of the window centred at
    ``xc_lo + j``.
    """
    h, w = ml.shape
    yc_lo = max(0, y - RADIUS)
    yc_hi = min(h - 1, y + RADIUS)
    xc_lo = max(0, x - RADIUS, d)  # right centre xc - d >= 0
    xc_hi = min(w - 1, x + RADIUS, w - 1 + d)
    if xc_lo > xc_hi:
        return UNDEFINED
    n_cols = xc_hi - xc_lo + 1
    for i in range(yc_hi - yc_lo + 1 + 2 * RADIUS):  # padded rows yc_lo .. yc_hi + 2 RADIUS
        py = yc_lo + i
        for j in range(n_cols + 2 * RADIUS):
            products[j] = np.float64(lp[py, xc_lo + j]) * np.float64(rp[py, xc_lo - d + j])
        for j in range(n_cols):
            s = 0.0
            for k in range(_SIDE):
                s += products[j + k]
            row_sums[i, j] = s
    best = UNDEFINED
    for yc in range(yc_lo, yc_hi + 1):
        for j in range(n_cols):
            xc = xc_lo + j
            a = nl[yc, xc]
            b = nr[yc, xc - d]
            if a <= 0.0 or b <= 0.0:
                continue  # UNDEFINED, never above best
            acc = 0.0
            for i in range(_SIDE):
                acc += row_sums[yc - yc_lo + i, j]
            cov = acc * (1.0 / (_SIDE * _SIDE)) - np.float64(ml[yc, xc]) * np.float64(mr[yc, xc - d])
            c = cov * a * b if kind == KIND_NCC else 2.0 * cov / (a + b)
            best = max(best, min(max(c, -1.0), 1.0))
    return best


@njit(cache=CACHE, nogil=True)
def _range_along_rows(lo_in, hi_in):
    """Minimum of ``lo_in`` and maximum of ``hi_in`` over the ``2 RADIUS + 1`` columns around each
    element of a row (clipped at the ends)."""
    h, w = lo_in.shape
    lo_out = np.empty((h, w), np.int64)
    hi_out = np.empty((h, w), np.int64)
    for y in range(h):
        for x in range(w):
            lo = lo_in[y, x]
            hi = hi_in[y, x]
            for xx in range(max(0, x - RADIUS), min(w, x + RADIUS + 1)):
                lo = min(lo, lo_in[y, xx])
                hi = max(hi, hi_in[y, xx])
            lo_out[y, x] = lo
            hi_out[y, x] = hi
    return lo_out, hi_out


@njit(cache=CACHE, nogil=True)
def _square_range(d_map):
    """Smallest and largest disparity of the matches in the ``(2 RADIUS + 1)^2`` square around each
    pixel (separable: rows, then columns); ``lo > hi`` where the square holds no match."""
    lo = np.where(d_map >= 0, d_map, np.iinfo(np.int64).max)
    row_lo, row_hi = _range_along_rows(lo, d_map)
    sq_lo, sq_hi = _range_along_rows(row_lo.T, row_hi.T)
    return sq_lo.T, sq_hi.T


@njit(cache=CACHE, nogil=True)
def _shifted_window_kernel(lp, rp, ml, nl, mr, nr, kind, d_map, ys, xs):
    """Keep flags of the matches ``(ys, xs)`` with integer disparities ``d_map`` (-1: unmatched).

    Only matches whose square holds a disparity more than 1 px away (from :func:`_square_range`)
    are scanned for their alternatives.
    """
    h, w = d_map.shape
    n = ys.shape[0]
    keep = np.ones(n, np.bool_)
    seen = np.empty(_SIDE * _SIDE, np.int64)
    products = np.empty(_TILE, np.float64)
    row_sums = np.empty((_TILE, _SIDE), np.float64)
    sq_lo, sq_hi = _square_range(d_map)
    n_checked = 0
    for i in range(n):
        y = ys[i]
        x = xs[i]
        d = d_map[y, x]
        if sq_hi[y, x] - d <= 1 and d - sq_lo[y, x] <= 1:
            continue
        own = 2.0  # not computed yet (similarities are <= 1)
        n_seen = 0
        for yy in range(max(0, y - RADIUS), min(h, y + RADIUS + 1)):
            for xx in range(max(0, x - RADIUS), min(w, x + RADIUS + 1)):
                a = d_map[yy, xx]
                if a < 0 or abs(a - d) <= 1 or not keep[i]:
                    continue
                new = True
                for k in range(n_seen):
                    if seen[k] == a:
                        new = False
                if not new:
                    continue
                seen[n_seen] = a
                n_seen += 1
                if own > 1.5:
                    own = _best_shifted(lp, rp, ml, nl, mr, nr, kind, y, x, d, products, row_sums)
                    n_checked += 1
                if _best_shifted(lp, rp, ml, nl, mr, nr, kind, y, x, a, products, row_sums) > own:
                    keep[i] = False
    return keep, n_checked
