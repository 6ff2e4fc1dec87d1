"""Joining the pieces of one object by where they stand on the ground.

An object whose matches have gaps comes out of the grouping as several obstacles, each measured
alone: a pole's top above a nearer box and its foot below it, a box's front edge and its top
face, the bonnet and the windscreen of a car. The list repeats the object, and the piece that
covers most of it need not be its nearest. Seen from above, the pieces of one object stand on
one place of the ground, and two objects cannot stand in one place. So each obstacle gets a
footprint: every image column of it with at least ``min_column_pixels`` matches gives a point
``(X, Z)`` in metres, its lateral position and its median depth in that column. Two obstacles
of one colour (median chroma within ``max_chroma_distance`` in ``(a*, b*)``, the colour split's
distinction of two colours) are pieces of one object when their footprints touch: at least
``min_close_columns`` points of each lie within ``max_gap_m`` of the other footprint, and so do
at least ``min_close_fraction`` of the points of the shorter one (a piece stands on, or next
to, the object it belongs to; an obstacle that mixes a wall with the box in front of it touches
the wall with only its wall columns).

The outermost ``edge_columns`` columns on either side of an obstacle are left out of its
footprint: the matching spreads an object's disparity over the background beside it, which puts
those columns at the object's depth but beside it, where they can touch a neighbour's footprint.

Joins form stars, not chains: the obstacles are taken largest first (in pixels), and each one not
yet joined takes every other one not yet joined whose footprint touches its own. A piece that
touches only another piece stays apart: an obstacle holding two objects the grouping could not
tell apart touches both, and would chain them to its other neighbours. The joined obstacles are
measured as one by :func:`stereo_obstacles.obstacle_joining.measure_joined`, between their
nearest and their largest piece in distance. Measured in ``docs/pipeline.md`` ("The pieces of
one object, joined by their footprints").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.colour_split import ColourSplitParameters
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import check_integers, check_numbers
from stereo_obstacles.obstacles import ObstacleList

TOUCH_BLOCK_POINTS = 1024
"""Points of the first footprint compared with the other at once (bounds the distance table's
memory: 1024 x 3000 points is 25 MB)."""

__all__ = ["FootprintJoiningParameters", "footprint", "pieces_of_one_object"]


@dataclass(frozen=True)
class FootprintJoiningParameters:
    """When two obstacles are pieces of one object (module docstring).

    Attributes
    ----------
    max_gap_m : float
        Footprint points this close (metres, on the ground plan ``X``, ``Z``) touch.
    min_close_columns : int
        Points of each footprint that must touch the other.
    min_close_fraction : float
        Fraction of the points of the footprint with fewer that must touch the other.
    max_chroma_distance : float
        The obstacles' median chroma must lie this close in ``(a*, b*)`` (CIE L*a*b* units).
    edge_columns : int
        Columns left out on either side of a footprint (kept when it has fewer than
        ``2 * edge_columns + 2``).
    min_column_pixels : int
        Matched pixels a column needs to give a footprint point.
    """

    max_gap_m: float = 0.3
    min_close_columns: int = 3
    min_close_fraction: float = 0.5
    max_chroma_distance: float = ColourSplitParameters.min_chroma_distance
    edge_columns: int = 4
    min_column_pixels: int = 3

    def __post_init__(self) -> None:
        check_numbers(self, (("max_gap_m", 0.0, math.inf), ("min_close_fraction", 0.0, 1.0),
                             ("max_chroma_distance", 0.0, 400.0)))
        check_integers(self, (("min_close_columns", 1, 10 ** 6), ("edge_columns", 0, 10 ** 6),
                              ("min_column_pixels", 1, 10 ** 6)))


def footprint(xs: np.ndarray, disparities: np.ndarray, calibration: StereoCalibration,
              params: FootprintJoiningParameters = FootprintJoiningParameters()) -> np.ndarray:
    """``float64 (n, 2)``: the footprint points ``(X, Z)`` in metres of an obstacle's pixels.

    ``xs`` (int, shape (N,)) are their columns, ``disparities`` (float, shape (N,), pixels, NaN:
    unmatched) their disparities. Each column with ``params.min_column_pixels`` matches whose
    median disparity plus ``doffs`` is positive gives one point, the outermost
    ``params.edge_columns`` columns on either side excepted (module docstring).

    Raises
    ------
    InvalidInputError
        ``xs`` not integer, or the two not 1-D arrays of one length.
    """
    xs, disparities = np.asarray(xs), np.asarray(disparities, dtype=np.float64)
    if xs.ndim != 1 or disparities.shape != xs.shape or not np.issubdtype(xs.dtype, np.integer):
        raise InvalidInputError(f"xs (integer columns) and disparities must be 1-D arrays of one length, got "
                                f"{xs.dtype} {xs.shape} and {disparities.shape}")
    matched = np.isfinite(disparities)
    xs, disparities = xs[matched], disparities[matched]
    if len(xs) == 0:
        return np.empty((0, 2))
    low, high = disparities.min(), disparities.max()
    # one sort by column, then disparity: the disparity scaled into [0, 0.5) after the column number
    # (3x faster than np.lexsort of the two on a 60 000-pixel obstacle)
    order = np.argsort(xs + 0.5 * (disparities - low) / (high - low) if high > low else xs)
    xs, disparities = xs[order], disparities[order]
    columns, starts, counts = np.unique(xs, return_index=True, return_counts=True)
    medians = 0.5 * (disparities[starts + (counts - 1) // 2] + disparities[starts + counts // 2])
    shifted = medians + calibration.doffs_px
    kept = (counts >= params.min_column_pixels) & (shifted > 0)
    columns, shifted = columns[kept], shifted[kept]
    if len(columns) >= 2 * params.edge_columns + 2:
        inner = ((columns >= columns.min() + params.edge_columns)
                 & (columns <= columns.max() - params.edge_columns))
        columns, shifted = columns[inner], shifted[inner]
    z = calibration.focal_baseline_px_m / shifted
    return np.stack([(columns - calibration.cx_px) * z / calibration.focal_px, z], axis=1)


def _touch(first: np.ndarray, second: np.ndarray, params: FootprintJoiningParameters) -> bool:
    """Whether the footprints (``(n, 2)`` metres) touch: ``min_close_columns`` points of each,
    and ``min_close_fraction`` of the shorter one's, lie within ``max_gap_m`` of the other one."""
    if len(first) < params.min_close_columns or len(second) < params.min_close_columns:
        return False
    near_first = np.zeros(len(first), dtype=bool)             # points of each within the gap of the other
    near_second = np.zeros(len(second), dtype=bool)
    for start in range(0, len(first), TOUCH_BLOCK_POINTS):
        block = first[start:start + TOUCH_BLOCK_POINTS]
        gaps = np.hypot(block[:, None, 0] - second[None, :, 0], block[:, None, 1] - second[None, :, 1])
        close = gaps <= params.max_gap_m
        near_first[start:start + len(block)] = close.any(axis=1)
        near_second |= close.any(axis=0)
    counts, lengths = (int(near_first.sum()), int(near_second.sum())), (len(first), len(second))
    shorter = [k for k in (0, 1) if lengths[k] == min(lengths)]          # both, when they are as long
    return (min(counts) >= params.min_close_columns
            and all(counts[k] >= params.min_close_fraction * lengths[k] for k in shorter))


def pieces_of_one_object(obstacles: ObstacleList, disparity: np.ndarray, chroma: np.ndarray,
                         calibration: StereoCalibration,
                         params: FootprintJoiningParameters = FootprintJoiningParameters()) -> list[tuple[int, int]]:
    """The pairs ``(host, piece)`` of obstacle ids to join (module docstring): each piece once.

    Parameters
    ----------
    obstacles
        The obstacles, whose ``id_map`` (``int (H, W)``, 0: none) says which pixels each covers.
    disparity
        ``float32 (H, W)`` disparity they were measured on, pixels, NaN where unmatched.
    chroma
        ``uint8 (H, W, 2)`` chroma of the left image
        (:attr:`stereo_obstacles.colour_split.ColourCue.chroma`).
    calibration
        The rig, for the footprints in metres.
    params
        When to join.

    Raises
    ------
    InvalidInputError
        A disparity or chroma of another height and width than the id map, chroma that is not
        ``uint8 (H, W, 2)``, or no calibration.
    """
    id_map, disparity, chroma = np.asarray(obstacles.id_map), np.asarray(disparity), np.asarray(chroma)
    if disparity.shape != id_map.shape or chroma.shape != id_map.shape + (2,) or chroma.dtype != np.uint8:
        raise InvalidInputError(f"disparity {disparity.shape} and chroma ({chroma.dtype} {chroma.shape}) must be "
                                f"(H, W) and uint8 (H, W, 2) for the id map's (H, W) = {id_map.shape}")
    if not isinstance(calibration, StereoCalibration):
        raise InvalidInputError(f"calibration must be a StereoCalibration (footprints are in metres), got "
                                f"{type(calibration).__name__}")
    pixels, colours = {}, {}
    for o in obstacles.obstacles:
        x0, y0, x1, y1 = o.box_px
        ys, xs = np.nonzero(id_map[y0:y1, x0:x1] == o.id)
        pixels[o.id] = (ys + y0, xs + x0)
        colours[o.id] = np.median(chroma[ys + y0, xs + x0], axis=0)
    prints: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}   # points, their low and high corner

    def footprint_of(k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if k not in prints:
            ys, xs = pixels[k]
            points = footprint(xs, disparity[ys, xs], calibration, params)
            if len(points):
                prints[k] = (points, points.min(axis=0), points.max(axis=0))
            else:
                prints[k] = (points, np.full(2, np.inf), np.full(2, -np.inf))
        return prints[k]

    ids = sorted(pixels)
    touching: dict[int, set[int]] = {k: set() for k in ids}
    for i, a in enumerate(ids):
        for b in ids[i + 1:]:
            if math.dist(colours[a], colours[b]) > params.max_chroma_distance:
                continue
            (first, low_a, high_a), (second, low_b, high_b) = footprint_of(a), footprint_of(b)
            # bounding boxes farther apart than the gap in X or Z: no point can touch (a cheap first test)
            if np.any(np.maximum(low_a, low_b) - np.minimum(high_a, high_b) > params.max_gap_m):
                continue
            if _touch(first, second, params):
                touching[a].add(b)
                touching[b].add(a)
    size = {o.id: o.pixel_count for o in obstacles.obstacles}
    joined: set[int] = set()
    pairs = []
    for host in sorted(ids, key=lambda k: (-size[k], k)):
        if host in joined or not touching[host]:
            continue
        joined.add(host)
        for piece in sorted(touching[host] - joined):
            joined.add(piece)
            pairs.append((host, piece))
    return pairs
