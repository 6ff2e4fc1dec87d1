"""Where a set of pixels stands on the ground: its footprint on the ground plan.

Seen from above, an object stands on one place of the ground, and two objects cannot stand in
one place. A set of matched pixels (an obstacle, or a part of one) gets a *footprint*: every image
column of it with at least ``min_column_pixels`` matches gives a point ``(X, Z)`` in metres, its
lateral position and its median depth in that column. The outermost ``edge_columns`` columns on
either side can be left out (:data:`EDGE_COLUMNS` by default, as the colour split takes them;
the footprint joining leaves none out since session 35): the matching spreads an object's
disparity over the background beside it, which puts those columns at the object's depth but
beside it.

Two footprints are compared by their *close points*: the points of each that lie within a gap of
the other footprint. The pieces of one object are joined when they touch that way
(:mod:`stereo_obstacles.footprint_joining`); two depths of one group are split only when they do
not (:mod:`stereo_obstacles.colour_split`).

A face that is not upright (the top face of a box or a wall, seen from above) covers a range of
depths in each column, and its median lies behind the edge where it meets the front face (a
wall's top face 0.6 m behind its front face, on the ground plan). Its *spans* keep that range: per
column, the segment of the column's line of sight between the depths at two quantiles of its
disparities (:func:`footprint_spans`); :func:`close_spans` compares them by the least distance
between two segments.
"""

from __future__ import annotations

import numpy as np

from stereo_obstacles._footprints_kernel import close_spans_kernel
from stereo_obstacles._obstacles_kernel import bucket_medians_kernel, bucket_quantiles_kernel
from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import is_finite_real

__all__ = ["EDGE_COLUMNS", "MIN_COLUMN_PIXELS", "close_points", "close_spans", "footprint", "footprint_spans"]

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
        positive, or so small that the depth overflows, give no point either.

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
    xs, disparities, first = _matched_columns(xs, disparities, edge_columns, min_column_pixels)
    if len(xs) == 0:
        return np.empty((0, 2))
    counts, medians = bucket_medians_kernel(xs - first, disparities, int(xs.max()) - first + 1)
    columns, (shifted,) = _kept_columns(counts, (medians,), first, calibration, edge_columns, min_column_pixels)
    z = calibration.focal_baseline_px_m / shifted
    return np.stack([(columns - calibration.cx_px) * z / calibration.focal_px, z], axis=1)


def footprint_spans(xs: np.ndarray, disparities: np.ndarray, calibration: StereoCalibration, *, quantile: float,
                    edge_columns: int = EDGE_COLUMNS, min_column_pixels: int = MIN_COLUMN_PIXELS) -> np.ndarray:
    """``float64 (n, 4)``: the spans ``(X near, Z near, X far, Z far)`` in metres of a set of
    pixels, one per column from left to right: the two ends, on the column's line of sight, of
    the depths at the ``1 - quantile`` and ``quantile`` quantiles of its disparities.

    ``xs``, ``disparities``, ``calibration``, ``edge_columns`` and ``min_column_pixels`` are as
    :func:`footprint` takes them; columns whose ``quantile`` disparity plus ``doffs`` is not
    positive, or so small that the depth overflows, give no span. ``quantile`` lies in
    ``[0, 0.5]``.

    Raises
    ------
    InvalidInputError
        As :func:`footprint`, and a ``quantile`` outside ``[0, 0.5]``.

    Examples
    --------
    >>> rig = StereoCalibration(focal_px=350.0, cx_px=160.0, cy_px=120.0, baseline_m=0.12)
    >>> top = np.array([8.0, 9.0, 10.0, 11.0, 12.0])   # a face receding from 3.5 m to 5.25 m
    >>> footprint_spans(np.full(5, 195), top, rig, quantile=0.25, edge_columns=0).round(2)  # at 11 and 9 px
    array([[0.38, 3.82, 0.47, 4.67]])
    """
    if not (is_finite_real(quantile) and 0.0 <= quantile <= 0.5):
        raise InvalidInputError(f"quantile must be a number in [0, 0.5], got {quantile!r}")
    xs, disparities, first = _matched_columns(xs, disparities, edge_columns, min_column_pixels)
    if len(xs) == 0:
        return np.empty((0, 4))
    counts, far, near = bucket_quantiles_kernel(xs - first, disparities, int(xs.max()) - first + 1,
                                                float(quantile), 1.0 - float(quantile))
    columns, (far, near) = _kept_columns(counts, (far, near), first, calibration, edge_columns, min_column_pixels)
    sideways = (columns - calibration.cx_px) / calibration.focal_px        # X / Z along each line of sight
    z_near, z_far = calibration.focal_baseline_px_m / near, calibration.focal_baseline_px_m / far
    return np.stack([sideways * z_near, z_near, sideways * z_far, z_far], axis=1)


def _matched_columns(xs: np.ndarray, disparities: np.ndarray, edge_columns: int,
                     min_column_pixels: int) -> tuple[np.ndarray, np.ndarray, int]:
    """The matched pixels' columns (``int64``) and disparities (``float64``), and their first
    column (0 when there are none); the four arguments checked as :func:`footprint` says."""
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
        return xs.astype(np.int64), disparities, 0
    first, last = int(xs.min()), int(xs.max())
    if last - first > MAX_COLUMN_SPAN or last > np.iinfo(np.int64).max:
        raise InvalidInputError(f"xs must be image columns at most {MAX_COLUMN_SPAN} apart and below 2**63, got "
                                f"{first} to {last}")
    return xs.astype(np.int64), disparities, first


def _kept_columns(counts: np.ndarray, disparities: tuple[np.ndarray, ...], first: int, calibration: StereoCalibration,
                  edge_columns: int, min_column_pixels: int) -> tuple[np.ndarray, tuple[np.ndarray, ...]]:
    """The columns that give a point, and their ``disparities`` (one array per statistic, each
    ``(number of columns,)`` from column ``first`` on) plus ``doffs``: the columns with at least
    ``min_column_pixels`` matches whose first statistic (the smallest disparity: a footprint's
    farthest depth) plus ``doffs`` is positive and gives a finite depth, the outermost
    ``edge_columns`` on either side left out when at least ``2 * edge_columns + 2`` remain."""
    held = np.flatnonzero(counts)
    shifted = tuple(d[held] + calibration.doffs_px for d in disparities)
    finite_depth = shifted[0] > calibration.focal_baseline_px_m / np.finfo(np.float64).max   # positive, Z finite
    kept = (counts[held] >= min_column_pixels) & finite_depth
    columns, shifted = held[kept] + first, tuple(d[kept] for d in shifted)
    if len(columns) >= 2 * edge_columns + 2:
        inner = (columns >= columns.min() + edge_columns) & (columns <= columns.max() - edge_columns)
        columns, shifted = columns[inner], tuple(d[inner] for d in shifted)
    return columns, shifted


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
    first, second = _checked_rows(first, second, 2, "points")
    near_first = np.zeros(len(first), dtype=bool)             # points of each within the gap of the other
    near_second = np.zeros(len(second), dtype=bool)
    for start in range(0, len(first), BLOCK_POINTS):
        block = first[start:start + BLOCK_POINTS]
        gaps = np.hypot(block[:, None, 0] - second[None, :, 0], block[:, None, 1] - second[None, :, 1])
        close = gaps <= max_gap_m
        near_first[start:start + len(block)] = close.any(axis=1)
        near_second |= close.any(axis=0)
    return int(near_first.sum()), int(near_second.sum())


def close_spans(first: np.ndarray, second: np.ndarray, max_gap_m: float) -> tuple[int, int]:
    """How many spans of each (``float (n, 4)`` and ``(m, 4)``, metres, as :func:`footprint_spans`
    gives them) lie within ``max_gap_m`` metres of a span of the other one, on the ground plan: the
    gap of two spans is the least distance between the two segments (0 where they cross).
    ``(0, 0)`` when either is empty.

    Raises
    ------
    InvalidInputError
        Spans that are not ``(n, 4)``.

    Examples
    --------
    >>> front = np.array([[0.0, 2.05, 0.0, 2.1], [0.1, 2.05, 0.1, 2.1]])
    >>> top = np.array([[0.0, 2.3, 0.0, 2.8], [0.1, 2.5, 0.1, 2.8]])    # 0.2 m and 0.4 m behind the front
    >>> close_spans(front, top, 0.3)
    (2, 1)
    """
    first, second = _checked_rows(first, second, 4, "spans")
    return close_spans_kernel(np.ascontiguousarray(first), np.ascontiguousarray(second), float(max_gap_m))


def _checked_rows(first, second, width: int, name: str) -> tuple[np.ndarray, np.ndarray]:
    """The two as ``float64`` arrays of ``width`` columns (else an :class:`InvalidInputError`)."""
    first, second = np.asarray(first, dtype=np.float64), np.asarray(second, dtype=np.float64)
    if first.ndim != 2 or second.ndim != 2 or first.shape[1] != width or second.shape[1] != width:
        raise InvalidInputError(f"footprints must be (n, {width}) arrays of {name}, got {first.shape} and "
                                f"{second.shape}")
    return first, second
