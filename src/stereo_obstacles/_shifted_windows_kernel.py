"""Compiled shifted-window check of final matches against foreground fattening (private).

The public wrappers are :func:`stereo_obstacles.shifted_windows.shifted_window_check` (matches as
lists of pixels) and :func:`~stereo_obstacles.shifted_windows.shifted_window_check_map` (as a map).

The nine windows a pixel is checked with overlap: at one disparity they are built from the
products of a ``(4 RADIUS + 1)^2`` tile (81 products instead of 9 x 25), summed along rows then
columns.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from stereo_obstacles._similarity_kernel import CACHE, FASTMATH, KIND_NCC, RADIUS, UNDEFINED

_SIDE = 2 * RADIUS + 1
_TILE = 4 * RADIUS + 1
_CENTRES = 3
"""Window centres along each axis: ``-RADIUS``, 0 and ``RADIUS`` from the pixel (nine windows)."""


@njit(cache=CACHE, inline="always", fastmath=FASTMATH)
def _best_shifted(lp, rp, ml, nl, mr, nr, kind, y, x, d, products, row_sums):
    """Best similarity at disparity ``d`` over nine windows containing left pixel ``(x, y)``:
    those centred on ``(x + a, y + b)`` for ``a, b`` in ``(-RADIUS, 0, RADIUS)`` (inside the image,
    right centre inside the image); :data:`UNDEFINED` when there is none.

    Scratch (float64): ``products`` of shape ``(4 RADIUS + 1,)`` holds one row of the tile of
    padded rows ``y - RADIUS + i``; ``row_sums`` of shape ``(4 RADIUS + 1, _CENTRES)``, at
    row ``i`` and column ``k`` (0, 1, 2), the sum of that row's products over the columns of the
    window centred at ``x - RADIUS + k * RADIUS``. The tile has a fixed size (loops the compiler
    unrolls); at the image border its reads are clamped into the padded images and only feed
    windows that are skipped.
    """
    h, w = ml.shape
    hp = h + 2 * RADIUS - 1  # last padded row and column
    wp = w + 2 * RADIUS - 1
    for i in range(_TILE):
        py = min(max(y - RADIUS + i, 0), hp)
        for j in range(_TILE):
            xl = min(max(x - RADIUS + j, 0), wp)
            xr = min(max(x - RADIUS - d + j, 0), wp)
            products[j] = np.float64(lp[py, xl]) * np.float64(rp[py, xr])
        for k in range(_CENTRES):
            s = 0.0
            for m in range(_SIDE):
                s += products[k * RADIUS + m]
            row_sums[i, k] = s
    best = UNDEFINED
    for ki in range(_CENTRES):
        ic = ki * RADIUS
        yc = y - RADIUS + ic
        if yc < 0 or yc >= h:
            continue
        for kj in range(_CENTRES):
            xc = x - RADIUS + kj * RADIUS
            if xc < 0 or xc >= w or xc - d < 0 or xc - d >= w:
                continue
            a = nl[yc, xc]
            b = nr[yc, xc - d]
            if a <= 0.0 or b <= 0.0:
                continue  # UNDEFINED, never above best
            acc = 0.0
            for i in range(_SIDE):
                acc += row_sums[ic + i, kj]
            cov = acc * (1.0 / (_SIDE * _SIDE)) - np.float64(ml[yc, xc]) * np.float64(mr[yc, xc - d])
            c = cov * a * b if kind == KIND_NCC else 2.0 * cov / (a + b)
            best = max(best, min(max(c, -1.0), 1.0))
    return best


MAPS_OK, MAPS_OUTSIDE, MAPS_REPEATED = 0, 1, 2
"""Status of :func:`_add_matches` and :func:`_add_match_map`: the matches are valid, one lies
outside the image (or has ``d < 0`` or ``x - d < 0``), a left pixel is matched twice."""


@njit(cache=CACHE, nogil=True)
def _add_matches(ys, xs, xrs, index, row_offset, d_map, for_max, for_min):
    """Write the matches ``index`` of a table of left pixels ``(xs, ys + row_offset)`` and right
    columns ``xrs`` into the ``(h, w)`` maps: ``d_map`` (int32 disparities ``x - x_right``, -1 where
    unmatched) and two float32 copies for OpenCV's square max and min (-1 and +inf where
    unmatched). Returns :data:`MAPS_OK` or the status of the first invalid match (the maps then
    hold the matches before it)."""
    h, w = d_map.shape
    for i in index:
        y = ys[i] + row_offset
        x = xs[i]
        d = x - xrs[i]
        if y < 0 or y >= h or x < 0 or x >= w or d < 0 or x - d < 0:
            return MAPS_OUTSIDE
        if d_map[y, x] >= 0:
            return MAPS_REPEATED
        d_map[y, x] = d
        for_max[y, x] = d
        for_min[y, x] = d
    return MAPS_OK


@njit(cache=CACHE, nogil=True)
def _add_match_map(disparity, d_map, for_max, for_min):
    """Write the matches of ``disparity`` (int32 ``(h, w)``, the integer disparity of each left
    pixel, negative where unmatched) into the maps as :func:`_add_matches` does. Returns
    :data:`MAPS_OK` or the status of the first invalid match (``x - d < 0``, or a pixel matched
    before).

    The test and the three writes repeat those of :func:`_add_matches` on purpose: through a
    shared compiled helper (inlined or not) this loop took 8 ms instead of 0.3 ms at 640x480."""
    for y in range(d_map.shape[0]):
        for x in range(d_map.shape[1]):
            d = disparity[y, x]
            if d < 0:
                continue
            if x - d < 0:
                return MAPS_OUTSIDE
            if d_map[y, x] >= 0:
                return MAPS_REPEATED
            d_map[y, x] = d
            for_max[y, x] = d
            for_min[y, x] = d
    return MAPS_OK


@njit(cache=CACHE, nogil=True)
def _count_jumps(d_map, lo, hi, jumps):
    """Write into ``jumps[y]`` (int64) for each image row y in ``[lo, hi)`` the number of pairs of
    horizontally neighbouring matches of ``d_map`` (int32 ``(h, w)``, -1 where unmatched) whose
    disparities differ by more than 1."""
    w = d_map.shape[1]
    for y in range(lo, hi):
        n = 0
        for x in range(w - 1):
            a = d_map[y, x]
            b = d_map[y, x + 1]
            if a >= 0 and b >= 0 and abs(a - b) > 1:
                n += 1
        jumps[y] = n


@njit(cache=CACHE, nogil=True)
def _check_rows_kernel(lp, rp, ml, nl, mr, nr, kind, d_map, sq_lo, sq_hi, top, lo, hi, rejected):
    """Check the matches of image rows ``[lo, hi)``: set ``rejected[y, x]`` where a neighbouring
    disparity beats the match's own; returns the number of matches compared.

    ``d_map``, ``rejected``: ``(h, w)`` maps of the whole image (integer disparities, -1 where
    unmatched; verdicts). ``sq_lo``, ``sq_hi``: smallest and largest disparity of the matches in
    the ``(2 RADIUS + 1)^2`` square around each pixel of image rows ``top, top + 1, ...``; only
    matches whose square holds a disparity more than 1 px away are scanned for alternatives.
    """
    h, w = d_map.shape
    seen = np.empty(_SIDE * _SIDE, np.int64)
    products = np.empty(_TILE, np.float64)
    row_sums = np.empty((_TILE, _CENTRES), np.float64)
    n_checked = 0
    for y in range(lo, hi):
        for x in range(w):
            d = d_map[y, x]
            if d < 0 or (sq_hi[y - top, x] - d <= 1 and d - sq_lo[y - top, x] <= 1):
                continue
            own = 2.0  # not computed yet (similarities are <= 1)
            n_seen = 0
            beaten = False
            for yy in range(max(0, y - RADIUS), min(h, y + RADIUS + 1)):
                for xx in range(max(0, x - RADIUS), min(w, x + RADIUS + 1)):
                    a = d_map[yy, xx]
                    if a < 0 or abs(a - d) <= 1 or beaten:
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
                        beaten = True
            rejected[y, x] = beaten
    return n_checked
