"""Compiled growth of correspondence seeds over the disparity space (private).

The public wrapper is :func:`stereo_obstacles.growing.grow`. Data structures:

* memo table: for each left pixel ``(y, x)`` up to ``n_slots`` slots, each holding a
  disparity code ``(d - d_min) * 2 + in_T`` and its similarity; ``fill[y, x]`` counts the
  used slots. Laid out pixel-major ``(H, W, n_slots)`` so that a look-up reads one or two
  cache lines (slot-major was 5x slower). Every point's similarity is computed at most once; a point
  arriving at a full pixel is computed but not stored (counted as an overflow) and can
  never join the candidate table.
* candidate table T: parallel arrays ``t_y, t_x, t_xr, t_c`` sized ``K * H * W`` (the
  per-pixel cap bounds it; ``np.empty`` pages are only touched as used). Never reassigned
  in the loop: loop-carried array variables make numba emit atomic reference counting on
  every iteration (measured: 65 % of the growth time).
* priority queue: a bucket queue over similarity quantised in ``n_buckets`` steps on
  ``[tau, 1]``, one linked list (``head``/``nxt``) per bucket; pops the highest non-empty
  bucket.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from stereo_obstacles._similarity_kernel import CACHE, KIND_NCC, RADIUS, UNDEFINED, _similarity

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
def _grow_kernel(lp, rp, ml, nl, mr, nr, kind, seed_y, seed_x, seed_xr, seed_c, d_min, d_max,
                 tau, mu, k_max, use_max, greedy, n_slots, n_buckets):
    h, w = ml.shape
    side = 2 * RADIUS + 1
    keys = np.empty((h, w, n_slots), np.int16)
    vals = np.empty((h, w, n_slots), np.float32)
    fill = np.zeros((h, w), np.int32)
    best_l = np.full((h, w), -2.0, np.float32)
    best_r = np.full((h, w), -2.0, np.float32)
    cnt_l = np.zeros((h, w), np.int32)
    cnt_r = np.zeros((h, w), np.int32)
    counters = np.zeros(N_COUNTERS, np.int64)
    cap = h * w * (1 if greedy else k_max)  # the per-pixel cap bounds the table
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
    i = -1
    while True:  # the seeds first (step 0), then pops until the queue is empty
        i += 1
        if i < n_seeds:
            qy = seed_y[i]
            qx = seed_x[i]
            qxr = seed_xr[i]
            qc = np.float64(seed_c[i])
            code = qx - qxr - d_min
            qslot = _find_slot(keys, fill, qy, qx, code)
            if qslot < 0:
                qslot = _store(keys, vals, fill, counters, qy, qx, code, qc)
            n_groups = 1
        else:
            while top >= 0 and head[top] < 0:
                top -= 1
            if top < 0:
                break
            p = head[top]
            head[top] = nxt[p]
            y = t_y[p]
            x = t_x[p]
            xr = t_xr[p]
            n_groups = 4
        for g in range(n_groups):
            if i >= n_seeds:  # the best point of group g
                qc = -3.0
                qslot = -1
                for k in range(_GROUP_START[g], _GROUP_START[g + 1]):
                    py = y + _NEIGHBOURS[k, 0]
                    px = x + _NEIGHBOURS[k, 1]
                    pxr = xr + _NEIGHBOURS[k, 2]
                    if py < 0 or py >= h or px < 0 or px >= w or pxr < 0 or pxr >= w:
                        continue
                    code = px - pxr - d_min
                    if code < 0 or code > d_max - d_min:
                        continue
                    # Memoised similarity, written out here rather than calling _find_slot,
                    # _store and _similarity: array arguments of calls in this loop cost
                    # atomic reference counting (4x slower, measured). Same formula as
                    # _similarity_kernel._similarity (the tests check they agree).
                    s = -1
                    for kk in range(fill[py, px]):
                        if keys[py, px, kk] >> 1 == code:
                            s = kk
                            break
                    if s >= 0:
                        c = np.float64(vals[py, px, s])
                    else:
                        a = nl[py, px]
                        b = nr[py, pxr]
                        if a <= 0.0 or b <= 0.0:
                            c = UNDEFINED
                        else:
                            acc = 0.0
                            for ii in range(side):
                                for jj in range(side):
                                    acc += np.float64(lp[py + ii, px + jj]) * np.float64(rp[py + ii, pxr + jj])
                            cov = acc / (side * side) - np.float64(ml[py, px]) * np.float64(mr[py, pxr])
                            c = cov * a * b if kind == KIND_NCC else 2.0 * cov / (a + b)
                            c = np.float64(np.float32(min(max(c, -1.0), 1.0)))  # as stored
                        counters[COUNT_COMPUTED] += 1
                        n = fill[py, px]
                        if n < n_slots:
                            keys[py, px, n] = np.int16(code * 2)
                            vals[py, px, n] = c
                            fill[py, px] = n + 1
                            s = n
                        else:
                            counters[COUNT_OVERFLOW] += 1
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
                if i >= n_seeds and qc + mu < ref:
                    continue
            keys[qy, qx, qslot] |= 1
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
