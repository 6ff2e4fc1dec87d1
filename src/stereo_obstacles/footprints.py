"""Where a set of pixels stands on the ground: its footprint on the ground plan.

Seen from above, an object stands on one place of the ground, and two objects cannot stand in
one place. A set of matched pixels (an obstacle, or a part of one) gets a *footprint*: every image
column of it with at least ``min_column_pixels`` matches gives a point ``(X, Z)`` in metres, its
lateral position and its median depth in that column. The outermost ``edge_columns`` columns on
either side are left out: the matching spreads an object's disparity over the background beside
it, which puts those columns at the object's depth but beside it.

Two footprints are compared by their *close points*: the points of each that lie within a gap of
the other footprint. The pieces of one object are joined when they touch that way
(:mod:`stereo_obstacles.footprint_joining`); two depths of one group are split only when they do
not (:mod:`stereo_obstacles.colour_split`).
"""

from __future__ import annotations

import numpy as np

from stereo_obstacles._obstacles_kernel import bucket_medians_kernel
from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.errors import InvalidInputError

__all__ = ["EDGE_COLUMNS", "MIN_COLUMN_PIXELS", "close_points", "footprint"]

EDGE_COLUMNS = 4
"""Columns left out on either side of a footprint (kept when it has fewer than ``2 *
EDGE_COLUMNS + 2``)."""
MIN_COLUMN_PIXELS = 3
"""Matched pixels a column needs to give a footprint point."""
MAX_COLUMN_SPAN = 1 << 20
"""Most columns a footprint's matched pixels may lie apart: far beyond any camera's width (the
column medians take a table of that many columns)."""
BLOCK_POINTS = 256
"""Points of the first footprint compared with the other at once: bounds the memory of the three
tables (the two differences and the distances, float64) a block takes, 18 MB against a footprint
of 3000 points."""


def footprint(xs: np.ndarray, disparities: np.ndarray, calibration: StereoCalibration, *,
              edge_columns: int = EDGE_COLUMNS, min_column_pixels: int = MIN_COLUMN_PIXELS) -> np.ndarray:
    """``float64 (n, 2)``: the footprint points ``(X, Z)`` in metres of a set of pixels, one per
    column from left to right.

    Parameters
    ----------
    xs
        ``int (N,)``: the pixels' columns.
    disparities
        ``float (N,)``: their disparities in pixels, NaN where unmatched.
    calibration
        The rig: ``Z = f B / (d + doffs)``, ``X = (x - cx) Z / f``.
    edge_columns
        Columns left out on either side (none when fewer than ``2 * edge_columns + 2`` remain).
    min_column_pixels
        Matches a column needs (at least 1); columns whose median disparity plus ``doffs`` is not
        positive give no point either.

    Raises
    ------
    InvalidInputError
        ``xs`` not integer, the two not 1-D arrays of one length, matched pixels more than
        :data:`MAX_COLUMN_SPAN` columns apart or at 2**63 or beyond, ``edge_columns`` below 0 or
        ``min_column_pixels`` below 1.

    Examples
    --------
    >>> rig = StereoCalibration(focal_px=350.0, cx_px=160.0, cy_px=120.0, baseline_m=0.12)
    >>> footprint(np.repeat([150, 151], 3), np.full(6, 10.0), rig, edge_columns=0)  # 4.2 m away
    array([[-0.12 ,  4.2  ],
           [-0.108,  4.2  ]])
    """
    xs, disparities = np.asarray(xs), np.asarray(disparities, dtype=np.float64)
    if xs.ndim != 1 or disparities.shape != xs.shape or not np.issubdtype(xs.dtype, np.integer):
        raise InvalidInputError(f"xs (integer columns) and disparities must be 1-D arrays of one length, got "
                                f"{xs.dtype} {xs.shape} and {disparities.shape}")
    if not (isinstance(edge_columns, (int, np.integer)) and edge_columns >= 0
            and isinstance(min_column_pixels, (int, np.integer)) and min_column_pixels >= 1):
        raise InvalidInputError(f"edge_columns must be an integer >= 0 and min_column_pixels an integer >= 1, got "
                                f"{edge_columns!r} and {min_column_pixels!r}")
    matched = np.isfinite(disparities)
    xs, disparities = xs[matched], disparities[matched]
    if len(xs) == 0:
        return np.empty((0, 2))
    first, last = int(xs.min()), int(xs.max())
    if last - first > MAX_COLUMN_SPAN or last > np.iinfo(np.int64).max:
        raise InvalidInputError(f"xs must be image columns at most {MAX_COLUMN_SPAN} apart and below 2**63, got "
                                f"{first} to {last}")
    counts, medians = bucket_medians_kernel(xs.astype(np.int64) - first, disparities, last - first + 1)
    held = np.flatnonzero(counts)
    columns, counts, medians = held + first, counts[held], medians[held]
    shifted = medians + calibration.doffs_px
    kept = (counts >= min_column_pixels) & (shifted > 0)
    columns, shifted = columns[kept], shifted[kept]
    if len(columns) >= 2 * edge_columns + 2:
        inner = (columns >= columns.min() + edge_columns) & (columns <= columns.max() - edge_columns)
        columns, shifted = columns[inner], shifted[inner]
    z = calibration.focal_baseline_px_m / shifted
    return np.stack([(columns - calibration.cx_px) * z / calibration.focal_px, z], axis=1)


def close_points(first: np.ndarray, second: np.ndarray, max_gap_m: float) -> tuple[int, int]:
    """How many points of each footprint (``float (n, 2)`` and ``(m, 2)``, metres, as
    :func:`footprint` gives them) lie within ``max_gap_m`` metres of the other one; ``(0, 0)``
    when either is empty.

    Raises
    ------
    InvalidInputError
        A footprint that is not ``(n, 2)``.

    Examples
    --------
    >>> wall = np.array([[0.0, 5.0], [0.1, 5.0], [0.2, 5.0]])
    >>> close_points(wall, np.array([[0.2, 4.8], [1.0, 4.8]]), 0.3)  # the wall, and one point of the other
    (3, 1)
    """
    first, second = np.asarray(first, dtype=np.float64), np.asarray(second, dtype=np.float64)
    if first.ndim != 2 or second.ndim != 2 or first.shape[1] != 2 or second.shape[1] != 2:
        raise InvalidInputError(f"footprints must be (n, 2) arrays of points, got {first.shape} and {second.shape}")
    near_first = np.zeros(len(first), dtype=bool)             # points of each within the gap of the other
    near_second = np.zeros(len(second), dtype=bool)
    for start in range(0, len(first), BLOCK_POINTS):
        block = first[start:start + BLOCK_POINTS]
        gaps = np.hypot(block[:, None, 0] - second[None, :, 0], block[:, None, 1] - second[None, :, 1])
        close = gaps <= max_gap_m
        near_first[start:start + len(block)] = close.any(axis=1)
        near_second |= close.any(axis=0)
    return int(near_first.sum()), int(near_second.sum())
