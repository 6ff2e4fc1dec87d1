"""The right-image cover, written out slowly, for the reference versions of the visibility and
hidden-ground tests: each match of a row covers the right-image columns it projects to,
together with the next match of its row when the two are one surface."""

from __future__ import annotations

import math

import numpy as np


def matches_of_row(row: np.ndarray) -> list[int]:
    """Columns of the matches of one row (float ``(W,)``): finite and at most ``2 W``."""
    w = row.shape[0]
    return [x for x in range(w) if math.isfinite(row[x]) and abs(row[x]) <= 2 * w]


def reference_cover(row: np.ndarray, max_gap_px: int, surface_tolerance_px: float) -> list[float]:
    """Nearest disparity seen at each right-image column of one row (float64 ``(W,)``), ``-inf``
    where none; two matches at most ``max_gap_px`` apart and within ``surface_tolerance_px``
    cover the columns between their projections too."""
    w = row.shape[0]
    xs = matches_of_row(row)
    cover = [-math.inf] * w
    for i, xa in enumerate(xs):
        low, high, seen = xa - row[xa] - 0.5, xa - row[xa] + 0.5, row[xa]
        if i + 1 < len(xs):
            xb = xs[i + 1]
            if xb - xa <= max_gap_px and abs(row[xb] - row[xa]) <= surface_tolerance_px:
                low, high = min(low, xb - row[xb] - 0.5), max(high, xb - row[xb] + 0.5)
                seen = min(seen, row[xb])
        for r in range(w):
            if low <= r <= high:
                cover[r] = max(cover[r], seen)
    return cover


def random_disparity_rows(seed: int, levels: list[float], shape: tuple[int, int]) -> np.ndarray:
    """float32 ``shape`` disparities: surfaces at the ``levels`` (pixels) with noise of 0.6 px, 30 %
    of the pixels unmatched (NaN); the random maps the kernels are compared with their references on."""
    rng = np.random.default_rng(seed)
    d = rng.choice(levels, size=shape) + rng.normal(0, 0.6, shape)
    d[rng.random(shape) < 0.3] = np.nan
    return d.astype(np.float32)
