"""Compiled passes of the ground colour model (see :mod:`stereo_obstacles.ground_colour`)."""

from __future__ import annotations

import numpy as np
from numba import njit

GROUND_BIT, SHADOW_BIT, SUNLIT_BIT, NEAR_BIT = 1, 2, 4, 8
"""Bits of a colour-table cell: the colour of lit reference ground, of that ground in cast
shadow, of sunlit ground seen from a shadowed reference, and "near any of them" (veto test)."""


@njit(cache=True, nogil=True)
def ground_cells_kernel(samples, lut, column_strip, n_strips, quorum, min_count, n_bins):
    """Flat indices (``int64``) of the cells shown by enough strips of the reference area.

    ``samples`` is ``(n_scales, h, w, 3)``: the reference area at each texture scale, raw
    channel values mapped to cells by ``lut``; column ``x`` belongs to strip
    ``column_strip[x]``. A cell is ground when at least ``min_count`` samples of each of at
    least ``quorum`` strips fall in it.
    """
    n_cells = n_bins * n_bins * n_bins
    seen = np.zeros(n_cells, dtype=np.bool_)
    compact = np.empty(n_cells, dtype=np.int32)     # read only where seen: no need to clear it
    n_samples = samples.shape[0] * samples.shape[1] * samples.shape[2]
    cells = np.empty(n_samples, dtype=np.int64)
    ids = np.empty(n_samples, dtype=np.int32)
    n_seen = 0
    i = 0
    for k in range(samples.shape[0]):
        for y in range(samples.shape[1]):
            for x in range(samples.shape[2]):
                flat = ((lut[samples[k, y, x, 0]] * n_bins + lut[samples[k, y, x, 1]]) * n_bins
                        + lut[samples[k, y, x, 2]])
                if not seen[flat]:
                    seen[flat] = True
                    compact[flat] = n_seen
                    cells[n_seen] = flat
                    n_seen += 1
                ids[i] = compact[flat]
                i += 1
    counts = np.zeros((n_seen, n_strips), dtype=np.int32)   # only the cells that occur
    i = 0
    for k in range(samples.shape[0]):
        for y in range(samples.shape[1]):
            for x in range(samples.shape[2]):
                counts[ids[i], column_strip[x]] += 1
                i += 1
    n_ground = 0
    for j in range(n_seen):
        agree = 0
        for s in range(n_strips):
            if counts[j, s] >= min_count:
                agree += 1
        if agree >= quorum:
            cells[n_ground] = cells[j]
            n_ground += 1
    return cells[:n_ground].copy()


@njit(cache=True, nogil=True)
def colour_histogram_kernel(rgb, lut, n_bins, step):
    """Pixel count per cell (``int64 (n_bins**3,)``) of every ``step``-th row and column."""
    hist = np.zeros(n_bins * n_bins * n_bins, dtype=np.int64)
    for y in range(0, rgb.shape[0], step):
        for x in range(0, rgb.shape[1], step):
            hist[(lut[rgb[y, x, 0]] * n_bins + lut[rgb[y, x, 1]]) * n_bins + lut[rgb[y, x, 2]]] += 1
    return hist


@njit(cache=True, nogil=True)
def shift_support_kernel(ground_cells, hist, n_bins, shifts):
    """Per row of ``shifts``: pixels of ``hist`` in the ground cells moved by that shift,
    counting each target cell once and leaving out the ground cells themselves."""
    n_cells = n_bins * n_bins * n_bins
    is_ground = np.zeros(n_cells, dtype=np.bool_)
    for j in range(ground_cells.shape[0]):
        is_ground[ground_cells[j]] = True
    stamp = np.full(n_cells, -1, dtype=np.int64)
    support = np.zeros(shifts.shape[0], dtype=np.int64)
    for k in range(shifts.shape[0]):
        for j in range(ground_cells.shape[0]):
            flat = ground_cells[j]
            rr = flat // (n_bins * n_bins) + shifts[k, 0]
            gg = (flat // n_bins) % n_bins + shifts[k, 1]
            bb = flat % n_bins + shifts[k, 2]
            if 0 <= rr < n_bins and 0 <= gg < n_bins and 0 <= bb < n_bins:
                target = (rr * n_bins + gg) * n_bins + bb
                if not is_ground[target] and stamp[target] != k:
                    stamp[target] = k
                    support[k] += hist[target]
    return support


@njit(cache=True, nogil=True)
def fill_table_kernel(ground_cells, n_bins, shifts, table):
    """Fill ``table`` (``uint8 (n, n, n)``, zeroed): every ground cell sets ``shifts[k, 3]``
    at itself plus ``shifts[k, :3]`` (bins) for every row ``k``; then ``NEAR_BIT`` marks every
    cell within one bin (Chebyshev) of a set cell. Only the set cells are visited, not the
    whole table (2 846 of 357 911 cells on the default scene)."""
    set_cells = np.empty((min(ground_cells.shape[0] * shifts.shape[0], n_bins ** 3), 3), dtype=np.int64)  # each once
    n_set = 0
    for j in range(ground_cells.shape[0]):
        flat = ground_cells[j]
        r = flat // (n_bins * n_bins)
        g = (flat // n_bins) % n_bins
        b = flat % n_bins
        for k in range(shifts.shape[0]):
            rr = r + shifts[k, 0]
            gg = g + shifts[k, 1]
            bb = b + shifts[k, 2]
            if 0 <= rr < n_bins and 0 <= gg < n_bins and 0 <= bb < n_bins and shifts[k, 3] != 0:
                if table[rr, gg, bb] == 0:
                    set_cells[n_set, 0], set_cells[n_set, 1], set_cells[n_set, 2] = rr, gg, bb
                    n_set += 1
                table[rr, gg, bb] |= shifts[k, 3]
    for i in range(n_set):
        r, g, b = set_cells[i, 0], set_cells[i, 1], set_cells[i, 2]
        for rr in range(max(r - 1, 0), min(r + 2, n_bins)):
            for gg in range(max(g - 1, 0), min(g + 2, n_bins)):
                for bb in range(max(b - 1, 0), min(b + 2, n_bins)):
                    table[rr, gg, bb] |= NEAR_BIT


@njit(cache=True, nogil=True)
def lookup_kernel(rgb, lut, table, min_sum, flags, veto):
    """Per pixel: ``flags[..., 0:3]`` the ground / shadow / sunlit bits of its colour cell,
    ``flags[..., 3]`` whether it is bright enough to measure (channel sum >= ``min_sum``),
    ``veto`` whether its colour is not even near any ground colour."""
    height, width = rgb.shape[0], rgb.shape[1]
    for y in range(height):
        for x in range(width):
            r = rgb[y, x, 0]
            g = rgb[y, x, 1]
            b = rgb[y, x, 2]
            cell = table[lut[r], lut[g], lut[b]]
            flags[y, x, 0] = cell & 1
            flags[y, x, 1] = (cell >> 1) & 1
            flags[y, x, 2] = (cell >> 2) & 1
            flags[y, x, 3] = np.int64(r) + np.int64(g) + np.int64(b) >= min_sum
            veto[y, x] = (cell & 8) == 0
