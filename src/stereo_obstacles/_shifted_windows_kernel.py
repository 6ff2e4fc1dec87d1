"""Compiled shifted-window check of final matches against foreground fattening (private).

The public wrapper is :func:`stereo_obstacles.shifted_windows.shifted_window_check`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from stereo_obstacles._similarity_kernel import CACHE, RADIUS, UNDEFINED, _similarity


@njit(cache=CACHE, nogil=True)
def _best_shifted(lp, rp, ml, nl, mr, nr, kind, y, x, d):
    """Best similarity at disparity ``d`` over the windows containing left pixel ``(x, y)``:
    the windows centred on every pixel of the ``(2 RADIUS + 1)^2`` square around it (inside the
    image, right centre inside the image); :data:`UNDEFINED` when there is none."""
    h, w = ml.shape
    best = UNDEFINED
    for yc in range(max(0, y - RADIUS), min(h, y + RADIUS + 1)):
        for xc in range(max(0, x - RADIUS), min(w, x + RADIUS + 1)):
            xr = xc - d
            if xr >= 0 and xr < w:
                best = max(best, _similarity(lp, rp, ml, nl, mr, nr, kind, yc, xc, xr))
    return best


@njit(cache=CACHE, nogil=True)
def _shifted_window_kernel(lp, rp, ml, nl, mr, nr, kind, d_map, ys, xs):
    """Keep flags of the matches ``(ys, xs)`` with integer disparities ``d_map`` (-1: unmatched)."""
    h, w = d_map.shape
    n = ys.shape[0]
    keep = np.ones(n, np.bool_)
    side = 2 * RADIUS + 1
    seen = np.empty(side * side, np.int64)
    n_checked = 0
    for i in range(n):
        y = ys[i]
        x = xs[i]
        d = d_map[y, x]
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
                    own = _best_shifted(lp, rp, ml, nl, mr, nr, kind, y, x, d)
                    n_checked += 1
                if _best_shifted(lp, rp, ml, nl, mr, nr, kind, y, x, a) > own:
                    keep[i] = False
    return keep, n_checked
