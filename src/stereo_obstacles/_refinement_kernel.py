"""Compiled full-resolution refinement of an estimated disparity map (private).

The public wrapper is :func:`stereo_obstacles.refinement.refine_disparity`, which validates
the estimate and splits the rows between threads.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from stereo_obstacles._similarity_kernel import CACHE, FASTMATH, _similarity

_NOT_COMPUTED = -9.0
"""Mark of a similarity not computed yet (below every similarity)."""


@njit(cache=CACHE, fastmath=FASTMATH, nogil=True)
def _refine_rows(left_pad, right_pad, mean_l, norm_l, mean_r, norm_r, kind, estimate, radius, tau, d_min, d_max,
                 y_lo, y_hi, d_out, c_out, c_minus_out, c_plus_out):
    """Climb to the similarity peak nearest the estimate, rows ``[y_lo, y_hi)``.

    For each pixel with a finite ``estimate[y, x]`` (float32 pixels), start at the rounded
    estimate moved into the admissible range ``[d_min, min(d_max, x)]``, and step to the better
    of ``d - 1`` and ``d + 1`` (a neighbour outside the range does not count) while it beats
    ``d`` and stays within ``radius`` of the start. The end is a match if it is a peak (a
    climb stopped by the radius while still rising is not) and reaches ``tau``: ``d_out[y, x]``
    (int32; otherwise left as it is) gets it, with its similarity and those at ``d - 1`` and
    ``d + 1`` (NaN outside the range). Returns the number of similarities computed.
    """
    w = estimate.shape[1]
    n = 2 * radius + 3
    sims = np.empty(n, np.float64)  # sims[k]: disparity start - radius - 1 + k
    n_computed = 0
    for y in range(y_lo, y_hi):
        for x in range(w):
            e = estimate[y, x]
            hi = min(d_max, x)
            if not (e == e) or abs(e) > 1e9 or hi < d_min:  # no estimate, or no admissible disparity
                continue
            start = min(max(int(np.floor(e + 0.5)), d_min), hi)
            first = start - radius - 1
            for k in range(n):
                sims[k] = _NOT_COMPUTED
            k = radius + 1
            while True:
                for j in range(k - 1, k + 2):
                    if sims[j] == _NOT_COMPUTED:
                        d = first + j
                        if d < d_min or d > hi:
                            sims[j] = np.nan
                        else:
                            sims[j] = _similarity(left_pad, right_pad, mean_l, norm_l, mean_r, norm_r, kind, y, x,
                                                  x - d)
                            n_computed += 1
                left = sims[k - 1] > sims[k]  # false for NaN
                right = sims[k + 1] > sims[k]
                if left and not (right and sims[k + 1] > sims[k - 1]) and k - 1 >= 1:
                    k -= 1
                elif right and k + 1 <= n - 2:
                    k += 1
                else:
                    break
            if sims[k - 1] > sims[k] or sims[k + 1] > sims[k] or not sims[k] >= tau:
                continue  # stopped by the radius while still rising, or below tau (or NaN)
            d_out[y, x] = first + k
            c_out[y, x] = sims[k]
            c_minus_out[y, x] = sims[k - 1]
            c_plus_out[y, x] = sims[k + 1]
    return n_computed
