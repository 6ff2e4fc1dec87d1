"""A slow, obviously correct pure-Python/NumPy Growing Correspondence Seeds, for tests only.

It follows the rules written in ``stereo_obstacles.growing`` and
``stereo_obstacles.stable_matching`` literally, with a dict as the candidate table and
``heapq`` as the queue. The priority reproduces the compiled bucket queue exactly: the
similarity quantised in ``n_buckets`` steps on ``[tau, 1]``, ties popped last-in first-out.
"""

from __future__ import annotations

import heapq

import numpy as np

GROUPS = (
    ((0, -1, -1), (0, -2, -1), (0, -1, -2)),
    ((0, 1, 1), (0, 2, 1), (0, 1, 2)),
    ((-1, 0, 0), (-1, -1, 0), (-1, 1, 0), (-1, 0, -1), (-1, 0, 1)),
    ((1, 0, 0), (1, -1, 0), (1, 1, 0), (1, 0, -1), (1, 0, 1)),
)


def window(image: np.ndarray, y: int, x: int) -> np.ndarray:
    """The 5 x 5 window centred on ``(x, y)``, mirrored at the border (OpenCV REFLECT_101)."""
    padded = np.pad(np.asarray(image, np.float64), 2, mode="reflect")
    return padded[y:y + 5, x:x + 5]


def similarity(left, right, y, x, xr, kind="ncc", min_std=1.0) -> float:
    """NCC or MNCC of two windows, straight from the definition; -1 for a flat window."""
    a = window(left, y, x)
    b = window(right, y, xr)
    if a.std() < min_std or b.std() < min_std:
        return -1.0
    cov = np.mean((a - a.mean()) * (b - b.mean()))
    c = cov / (a.std() * b.std()) if kind == "ncc" else 2 * cov / (a.var() + b.var())
    return float(np.clip(c, -1.0, 1.0))


def stored(c: float) -> float:
    """A similarity as the growth stores it: rounded to a multiple of 1 / 32767."""
    return float(np.rint(c * 32767.0)) / 32767.0


def grow(left, right, seeds, *, d_min, d_max, tau=0.6, mu=0.1, k_max=10, use_max=True, greedy=False,
         kind="ncc", min_std=1.0, n_buckets=8):
    """Candidate table ``{(y, x, xr): c}`` grown from ``seeds`` = list of ``(y, x, xr, c)``.

    Seeds must be given best first; those below ``tau`` are skipped.
    """
    h, w = left.shape
    memo = {}

    def sim(y, x, xr):
        if (y, x, xr) not in memo:
            memo[(y, x, xr)] = stored(similarity(left, right, y, x, xr, kind, min_std))
        return memo[(y, x, xr)]

    table = {}
    best_l, best_r, cnt_l, cnt_r = {}, {}, {}, {}
    heap = []
    counter = 0

    def add(q, c):
        nonlocal counter
        y, x, xr = q
        table[q] = c
        bucket = min(max(int((c - tau) * ((n_buckets - 1) / (1 - tau))), 0), n_buckets - 1)
        heapq.heappush(heap, (-bucket, -counter, q))
        counter += 1
        best_l[(y, x)] = max(best_l.get((y, x), -2.0), c)
        best_r[(y, xr)] = max(best_r.get((y, xr), -2.0), c)
        cnt_l[(y, x)] = cnt_l.get((y, x), 0) + 1
        cnt_r[(y, xr)] = cnt_r.get((y, xr), 0) + 1

    def admissible(q, c, is_seed):
        y, x, xr = q
        if c < tau or q in table:
            return False
        if greedy:
            return cnt_l.get((y, x), 0) == 0 and cnt_r.get((y, xr), 0) == 0
        if cnt_l.get((y, x), 0) >= k_max or cnt_r.get((y, xr), 0) >= k_max:
            return False
        bl, br = best_l.get((y, x), -2.0), best_r.get((y, xr), -2.0)
        return is_seed or c + mu >= (max(bl, br) if use_max else min(bl, br))

    for y, x, xr, c in seeds:
        memo.setdefault((y, x, xr), stored(c))
        if admissible((y, x, xr), memo[(y, x, xr)], True):
            add((y, x, xr), memo[(y, x, xr)])
    while heap:
        _, _, (y, x, xr) = heapq.heappop(heap)
        for group in GROUPS:
            best_q, best_c = None, -3.0
            for dy, dx, dxr in group:
                q = (y + dy, x + dx, xr + dxr)
                if not (0 <= q[0] < h and 0 <= q[1] < w and 0 <= q[2] < w and d_min <= q[1] - q[2] <= d_max):
                    continue
                c = sim(*q)
                if c > best_c:
                    best_q, best_c = q, c
            if best_q is not None and admissible(best_q, best_c, False):
                add(best_q, best_c)
    return table


def stable_matching(table, margin=0.1):
    """Winners (set of ``(y, x, xr)``) of the confidently stable matching of ``{(y, x, xr): c}``.

    ``table`` lists the candidates in table order (a dict keeps insertion order).
    """
    winners = set()
    rows = {}
    for q, c in table.items():
        rows.setdefault(q[0], []).append((q, c))
    for cands in rows.values():
        cands.sort(key=lambda qc: -qc[1])  # stable: equal similarities stay in table order
        done_l, done_r = set(), set()
        for (y, x, xr), c in cands:
            if x in done_l or xr in done_r:
                continue
            runner_up = -np.inf
            for (_, qx, qxr), qc in cands:
                if (qx, qxr) == (x, xr) or qx in done_l or qxr in done_r:
                    continue
                if (qx == x and abs(qxr - xr) > 1) or (qxr == xr and abs(qx - x) > 1):
                    runner_up = max(runner_up, qc)
            done_l.add(x)
            done_r.add(xr)
            if runner_up <= c - margin * abs(c):
                winners.add((y, x, xr))
    return winners
