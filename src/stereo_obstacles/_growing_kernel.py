"""Compiled growth of correspondence seeds over the disparity space (private).

The public wrapper is :func:`stereo_obstacles.growing.grow`. Data structures:

* memo table: for each left pixel ``(y, x)`` up to ``n_slots`` slots, each holding a
  disparity code ``(d - d_min) * 2 + in_T`` and its similarity; ``fill[y, x]`` counts the
  used slots. Laid out pixel-major ``(H, W, n_slots)`` so that a look-up reads one or two
  cache lines (slot-major was 5x slower). Every point's similarity is computed at most once; a point
  arriving at a full pixel is computed but not stored (counted as an overflow) and can
  never join the candidate table.
* candidate table T: parallel arrays ``t_y, t_x, t_xr, t_c`` (grown by doubling).
* priority queue: a bucket queue over similarity quantised in ``n_buckets`` steps on
  ``[tau, 1]``, one linked list (``head``/``nxt``) per bucket; pops the highest non-empty
  bucket.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from stereo_obstacles._similarity_kernel import CACHE, _similarity

# The 16-point disparity-space neighbourhood of (y, x, x') in 4 groups: (dy, dx, dx', group).
_NEIGHBOURS = np.array([
    (0, -1, -1, 0), (0, -2, -1, 0), (0, -1, -2, 0),
    (0, 1, 1, 1), (0, 2, 1, 1), (0, 1, 2, 1),
    (-1, 0, 0, 2), (-1, -1, 0, 2), (-1, 1, 0, 2), (-1, 0, -1, 2), (-1, 0, 1, 2),
    (1, 0, 0, 3), (1, -1, 0, 3), (1, 1, 0, 3), (1, 0, -1, 3), (1, 0, 1, 3),
], dtype=np.int64)
_GROUP_START = np.array([0, 3, 6, 11, 16], dtype=np.int64)

N_COUNTERS = 2
COUNT_COMPUTED = 0
COUNT_OVERFLOW = 1


@njit(cache=CACHE, inline="always")
def _find_slot(keys, fill, y, x, code):
    for k in range(fill[y, x]):
        if keys[y, x, k] >> 1 == code:
            return k
    return -1


@njit(cache=CACHE, inline="always")
def _store(keys, vals, fill, counters, y, x, code, c):
    n = fill[y, x]
    if n < keys.shape[2]:
        keys[y, x, n] = np.int16(code * 2)
        vals[y, x, n] = c
        fill[y, x] = n + 1
        return n
    counters[COUNT_OVERFLOW] += 1
    return -1


@njit(cache=CACHE, inline="always")
def _score(lp, rp, ml, nl, mr, nr, kind, keys, vals, fill, counters, y, x, xr, d_min):
    """Memoised similarity of ``(y, x, xr)``: returns ``(c, slot)``, slot -1 if not stored."""
    code = x - xr - d_min
    k = _find_slot(keys, fill, y, x, code)
    if k >= 0:
        return vals[y, x, k], k
    c = _similarity(lp, rp, ml, nl, mr, nr, kind, y, x, xr)
    counters[COUNT_COMPUTED] += 1
    return c, _store(keys, vals, fill, counters, y, x, code, c)


@njit(cache=CACHE)
def _enlarge(a, size):
    b = np.empty(size, a.dtype)
    b[:a.shape[0]] = a
    return b


@njit(cache=CACHE)
def _grow_kernel(lp, rp, ml, nl, mr, nr, kind, seed_y, seed_x, seed_xr, seed_c, d_min, d_max,
                 tau, mu, k_max, use_max, greedy, n_slots, n_buckets):
    h, w = ml.shape
    keys = np.empty((h, w, n_slots), np.int16)
    vals = np.empty((h, w, n_slots), np.float32)
    fill = np.zeros((h, w), np.int32)
    best_l = np.full((h, w), -2.0, np.float32)
    best_r = np.full((h, w), -2.0, np.float32)
    cnt_l = np.zeros((h, w), np.int32)
    cnt_r = np.zeros((h, w), np.int32)
    counters = np.zeros(N_COUNTERS, np.int64)
    cap = max(1024, 2 * h * w)
    t_y = np.empty(cap, np.int32)
    t_x = np.empty(cap, np.int32)
    t_xr = np.empty(cap, np.int32)
    t_c = np.empty(cap, np.float32)
    nxt = np.empty(cap, np.int32)
    head = np.full(n_buckets, -1, np.int32)
    bucket_scale = (n_buckets - 1) / max(1.0 - tau, 1e-6)
    n_t = 0
    top = -1
    n_seeds = seed_y.shape[0]
    step = -1
    while True:  # the seeds first, then pops until the queue is empty
        step += 1
        if step < n_seeds:
            y = seed_y[step]
            x = seed_x[step]
            xr = seed_xr[step]
            code = x - xr - d_min
            slot = _find_slot(keys, fill, y, x, code)
            if slot < 0:
                slot = _store(keys, vals, fill, counters, y, x, code, seed_c[step])
            n_cand = 1
        else:
            while top >= 0 and head[top] < 0:
                top -= 1
            if top < 0:
                break
            i = head[top]
            head[top] = nxt[i]
            y = t_y[i]
            x = t_x[i]
            xr = t_xr[i]
            n_cand = 4
        for g in range(n_cand):
            if step < n_seeds:
                qy, qx, qxr, qc, qslot = y, x, xr, seed_c[step], slot
            else:
                qc = -3.0
                qslot = -1
                qy = qx = qxr = 0
                for k in range(_GROUP_START[g], _GROUP_START[g + 1]):
                    py = y + _NEIGHBOURS[k, 0]
                    px = x + _NEIGHBOURS[k, 1]
                    pxr = xr + _NEIGHBOURS[k, 2]
                    if py < 0 or py >= h or px < 0 or px >= w or pxr < 0 or pxr >= w:
                        continue
                    d = px - pxr
                    if d < d_min or d > d_max:
                        continue
                    c, s = _score(lp, rp, ml, nl, mr, nr, kind, keys, vals, fill, counters,
                                  py, px, pxr, d_min)
                    if c > qc:
                        qc = c
                        qslot = s
                        qy = py
                        qx = px
                        qxr = pxr
            if qc < tau or qslot < 0 or keys[qy, qx, qslot] & 1:
                continue
            if greedy:
                if cnt_l[qy, qx] > 0 or cnt_r[qy, qxr] > 0:
                    continue
            else:
                if cnt_l[qy, qx] >= k_max or cnt_r[qy, qxr] >= k_max:
                    continue
                bl = best_l[qy, qx]
                br = best_r[qy, qxr]
                ref = max(bl, br) if use_max else min(bl, br)
                if step >= n_seeds and qc + mu < ref:
                    continue
            keys[qy, qx, qslot] |= 1
            if n_t == cap:
                cap *= 2
                t_y = _enlarge(t_y, cap)
                t_x = _enlarge(t_x, cap)
                t_xr = _enlarge(t_xr, cap)
                t_c = _enlarge(t_c, cap)
                nxt = _enlarge(nxt, cap)
            t_y[n_t] = qy
            t_x[n_t] = qx
            t_xr[n_t] = qxr
            t_c[n_t] = qc
            b = min(max(int((qc - tau) * bucket_scale), 0), n_buckets - 1)
            nxt[n_t] = head[b]
            head[b] = n_t
            if b > top:
                top = b
            n_t += 1
            best_l[qy, qx] = max(best_l[qy, qx], qc)
            best_r[qy, qxr] = max(best_r[qy, qxr], qc)
            cnt_l[qy, qx] += 1
            cnt_r[qy, qxr] += 1
    return t_y[:n_t], t_x[:n_t], t_xr[:n_t], t_c[:n_t], keys, vals, fill, counters


@njit(cache=CACHE)
def _side_similarities(lp, rp, ml, nl, mr, nr, kind, keys, vals, fill, counters, ys, xs, ds, d_min,
                       d_max):
    """Similarities at ``d - 1`` and ``d + 1`` of matches ``(ys, xs, ds)``; NaN where out of range."""
    n = ys.shape[0]
    w = ml.shape[1]
    c_minus = np.full(n, np.nan, np.float32)
    c_plus = np.full(n, np.nan, np.float32)
    for i in range(n):
        y = ys[i]
        x = xs[i]
        d = ds[i]
        if d - 1 >= d_min and x - d + 1 < w:
            c_minus[i] = _score(lp, rp, ml, nl, mr, nr, kind, keys, vals, fill, counters,
                                y, x, x - d + 1, d_min)[0]
        if d + 1 <= d_max and x - d - 1 >= 0:
            c_plus[i] = _score(lp, rp, ml, nl, mr, nr, kind, keys, vals, fill, counters,
                               y, x, x - d - 1, d_min)[0]
    return c_minus, c_plus
