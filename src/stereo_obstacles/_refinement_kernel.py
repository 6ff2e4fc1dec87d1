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
    """Climb to the similarity peak nearest the rounded estimate, rows ``[y_lo, y_hi)``.

    For each pixel with a finite ``estimate[y, x]`` (float32 pixels), start at
    ``d = round(estimate)`` and step to the better of ``d - 1`` and ``d + 1`` while it beats
    ``d`` and stays within ``radius`` of the start. If the final ``d`` reaches ``tau`` it goes
    to ``d_out[y, x]`` (int32; otherwise left as it is) with its similarity and those at
    ``d - 1`` and ``d + 1`` (NaN outside the range or the image). Returns the number of
    similarities computed.
    """
    w = estimate.shape[1]
    n = 2 * radius + 3
    sims = np.empty(n, np.float64)  # sims[k]: disparity start - radius - 1 + k
    n_computed = 0
    for y in range(y_lo, y_hi):
        for x in range(w):
            e = estimate[y, x]
            if not e == e:  # NaN: no estimate
                continue
            first = int(np.floor(e + 0.5)) - radius - 1
            for k in range(n):
                sims[k] = _NOT_COMPUTED
            k = radius + 1
            while True:
                for j in range(k - 1, k + 2):
                    if sims[j] == _NOT_COMPUTED:
                        d = first + j
                        if d < d_min or d > d_max or d > x or x - d >= w:
                            sims[j] = np.nan
                        else:
                            sims[j] = _similarity(left_pad, right_pad, mean_l, norm_l, mean_r, norm_r, kind, y, x,
                                                  x - d)
                            n_computed += 1
                if sims[k - 1] > sims[k] and sims[k - 1] >= sims[k + 1] and k - 1 >= 1:  # false for NaN
                    k -= 1
                elif sims[k + 1] > sims[k] and k + 1 <= n - 2:
                    k += 1
                else:
                    break
            if not sims[k] >= tau:  # also NaN
                continue
            d_out[y, x] = first + k
            c_out[y, x] = sims[k]
            c_minus_out[y, x] = sims[k - 1]
            c_plus_out[y, x] = sims[k + 1]
    return n_computed
