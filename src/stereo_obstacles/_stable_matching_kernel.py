"""Compiled confidently stable matching of the candidate table, row by row (private).

The public wrapper is :func:`stereo_obstacles.stable_matching.stable_matching`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from stereo_obstacles._similarity_kernel import CACHE


@njit(cache=CACHE, nogil=True)
def _best_first(c):
    """Stable order of ``c`` by decreasing value: a counting sort on ``2 * len(c)`` value bins,
    then an insertion sort that only moves items inside their bin. O(n) for spread values
    (a comparison sort per row was most of the stage's time)."""
    m = c.shape[0]
    if m == 0:
        return np.empty(0, np.int64)
    lo = c[0]
    hi = c[0]
    for k in range(1, m):  # one pass for both (two reductions were 6 % of the stage)
        lo = min(lo, c[k])
        hi = max(hi, c[k])
    n_bins = 2 * m
    scale = (n_bins - 1) / (hi - lo) if hi > lo else 0.0
    count = np.zeros(n_bins + 1, np.int64)
    for k in range(m):
        count[int((hi - c[k]) * scale) + 1] += 1
    for b in range(n_bins):
        count[b + 1] += count[b]
    order = np.empty(m, np.int64)
    for k in range(m):
        b = int((hi - c[k]) * scale)
        order[count[b]] = k
        count[b] += 1
    for k in range(1, m):  # bins are in order; fix the order inside each bin, keeping ties stable
        item = order[k]
        j = k - 1
        while j >= 0 and c[order[j]] < c[item]:
            order[j + 1] = order[j]
            j -= 1
        order[j + 1] = item
    return order


@njit(cache=CACHE, nogil=True)
def _rows(t_y, h):
    """Candidate indices grouped by row ``t_y`` in ``[0, h)`` (counting sort, table order inside a
    row): ``(start, items)``, row y is ``items[start[y]:start[y+1]]``."""
    start = np.zeros(h + 1, np.int64)
    for y in t_y:
        start[y + 1] += 1
    for y in range(h):
        start[y + 1] += start[y]
    pos = start[:-1].copy()
    items = np.empty(t_y.shape[0], np.int64)
    for i in range(t_y.shape[0]):
        items[pos[t_y[i]]] = i
        pos[t_y[i]] += 1
    return start, items


@njit(cache=CACHE, nogil=True)
def _link_by(col, head, link):
    """Lists of the local indices ``k`` by pixel ``col[k]``: ``head[x]`` is the first, ``link[k]``
    the next (-1 ends a list). ``head`` is all -1 on entry (the caller resets what it used)."""
    for k in range(col.shape[0]):
        link[k] = head[col[k]]
        head[col[k]] = k


@njit(cache=CACHE, nogil=True)
def _stable_matching_kernel(t_x, t_xr, t_c, row_start, by_row, w, margin, row_lo, row_hi, winner):
    """Winners of the confidently stable matching (see ``stable_matching.py``) of rows
    ``[row_lo, row_hi)``, written into ``winner`` (bool (N,), False on entry) and returned as
    candidate indices (int64), row by row and in ``by_row`` order inside a row; the candidates of
    row y are ``by_row[row_start[y]:row_start[y + 1]]`` (:func:`_rows`).

    Each row's candidates are copied, best first, into small local arrays (the table is in
    growth order, so a row's candidates are scattered over it); the candidates sharing a left
    (right) pixel are linked lists through those arrays, so a row costs O(its candidates), not
    O(W). Serial: rows in parallel (``prange``) were slower on the shared 2-core machine (Cones,
    172 k candidates: 19.8 ms wall with two threads, 16.9 ms with one); the row bands run it in
    parallel instead, and hand pieces of rows to idle threads (``banded.py``).
    """
    n = t_x.shape[0]
    done_l = np.zeros(w, np.bool_)
    done_r = np.zeros(w, np.bool_)
    head_l = np.full(w, -1, np.int64)
    head_r = np.full(w, -1, np.int64)
    link_l = np.empty(n, np.int64)
    link_r = np.empty(n, np.int64)
    won = np.empty(row_start[row_hi] - row_start[row_lo], np.int64)
    n_won = 0
    for y in range(row_lo, row_hi):
        cand = by_row[row_start[y]:row_start[y + 1]]
        m = cand.shape[0]
        if m == 0:
            continue
        # best first, ties in table order (the counting sort kept it)
        idx = cand[_best_first(t_c[cand])]
        lx = t_x[idx]
        lxr = t_xr[idx]
        lc = t_c[idx]
        _link_by(lx, head_l, link_l)
        _link_by(lxr, head_r, link_r)
        for k in range(m):
            x = lx[k]
            xr = lxr[k]
            if done_l[x] or done_r[xr]:
                continue  # a better candidate took (or blocked) one of its pixels
            runner_up = -np.inf
            q = head_l[x]
            while q >= 0:
                if q != k and not done_r[lxr[q]] and abs(lxr[q] - xr) > 1:
                    runner_up = max(runner_up, lc[q])
                q = link_l[q]
            q = head_r[xr]
            while q >= 0:
                if q != k and not done_l[lx[q]] and abs(lx[q] - x) > 1:
                    runner_up = max(runner_up, lc[q])
                q = link_r[q]
            done_l[x] = True
            done_r[xr] = True
            c = lc[k]
            if runner_up <= c - margin * abs(c):
                winner[idx[k]] = True
        for k in range(m):  # clear the row's marks and lists for the next row
            done_l[lx[k]] = False
            done_r[lxr[k]] = False
            head_l[lx[k]] = -1
            head_r[lxr[k]] = -1
        for i in cand:
            if winner[i]:
                won[n_won] = i
                n_won += 1
    return won[:n_won]
