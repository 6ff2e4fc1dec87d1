"""Joining the pieces of one object by where they stand on the ground.

An object whose matches have gaps comes out of the grouping as several obstacles, each measured
alone: a pole's top above a nearer box and its foot below it, a box's front edge and its top
face, the bonnet and the windscreen of a car. The list repeats the object, and the piece that
covers most of it need not be its nearest. Seen from above, the pieces of one object stand on
one place of the ground, and two objects cannot stand in one place. So each obstacle gets a
footprint (:mod:`stereo_obstacles.footprints`): a point ``(X, Z)`` in metres for every image
column of it with at least ``min_column_pixels`` matches (its outermost ``edge_columns`` columns
on either side can be left out, the matching's fattened fringe; none are in the pipeline since
session 35: with 4 left out, two pieces of a far wall that share 13 image columns stood 0.31 m
apart, and over the synthetic sets the cases above 5 % fell from 72 to 70 and the repeated
detections from 605 to 535 with none left out; ``docs/pipeline.md``, "Faces that meet at an
edge, and two halo filters"). Two obstacles of one colour (median chroma within
``max_chroma_distance`` in ``(a*, b*)``, the colour split's distinction of two colours) are
pieces of one object when their footprints touch: at least ``min_close_columns`` points of each
lie within ``max_gap_m`` of the other footprint, and so do at least ``min_close_fraction`` of
the points of the shorter one (a piece stands on, or next to, the object it belongs to; an
obstacle that mixes a wall with the box in front of it touches the wall with only its wall
columns). Two obstacles that coincide stand in one place and are joined whatever their colours:
a thin piece's median chroma is pulled by the sky or ground that its fattened fringe covers (two
pieces of a thin pole, 13 and 8 columns wide: 21 apart in ``(a*, b*)``), and the top face of a
wall or a box, lit by the sun, is not the colour of its front face. Whether they coincide is
asked of their spans (each column's line of sight between the depths at the ``1 -
span_quantile`` and ``span_quantile`` quantiles of its disparities): at least
``min_close_columns`` and ``min_coincident_fraction`` of the spans of each lie within
``max_gap_m`` of the other's. A column's median alone puts the top face of a wall 0.6 m behind
its front face, though the two meet at the wall's edge; for an upright piece the span is short,
and close to its point. The one-colour test keeps the points: the spans of an obstacle that
mixes a box with the wall behind it reach across the gap between the two, and touch both
(``docs/pipeline.md``, "Faces that meet at an edge, and two halo filters", session 35).

Two obstacles side by side in the image with the background showing between them are two
objects, however their footprints lie (:mod:`stereo_obstacles.seen_through`): two leaning poles'
footprints can meet end to end.

Joins form stars, not chains: the obstacles are taken largest first (in pixels), and each one not
yet joined takes every other one not yet joined whose footprint touches its own. A piece that
touches only another piece stays apart: an obstacle holding two objects the grouping could not
tell apart touches both, and would chain them to its other neighbours. The joined obstacles are
measured as one by :func:`stereo_obstacles.obstacle_joining.measure_joined`, no farther than
their largest piece. Measured in ``docs/pipeline.md`` ("The pieces of one object, joined by
their footprints", and session 32 for coinciding footprints).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.colour_split import ColourCue, ColourSplitParameters
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import check_integers, check_numbers, check_types
from stereo_obstacles.footprints import MIN_COLUMN_PIXELS, close_points, close_spans, footprint, footprint_spans
from stereo_obstacles.obstacles import ObstacleList, obstacle_pixels
from stereo_obstacles.seen_through import SeenThroughParameters, background_between

__all__ = ["FootprintJoiningParameters", "pieces_of_one_object"]


@dataclass(frozen=True)
class FootprintJoiningParameters:
    """When two obstacles are pieces of one object (module docstring).

    Attributes
    ----------
    max_gap_m : float
        Footprint points, or spans, this close (metres, on the ground plan ``X``, ``Z``; for spans
        the least distance between the two segments) touch.
    min_close_columns : int
        Points (for the coincide test, spans) of each footprint that must touch the other's.
    min_close_fraction : float
        Fraction of the points of the footprint with fewer that must touch the other.
    max_chroma_distance : float
        The obstacles' median chroma must lie this close in ``(a*, b*)`` (CIE L*a*b* units), unless
        they coincide.
    min_coincident_fraction : float
        Fraction of the spans of each obstacle that must touch the other's for the two to
        coincide.
    span_quantile : float
        A column's span reaches from the depth at the ``1 - span_quantile`` quantile of its
        disparities to the depth at the ``span_quantile`` quantile, in ``[0, 0.5]`` (0.5: its
        median, the footprint's point).
    edge_columns : int
        Columns left out on either side of a footprint (kept when it has fewer than
        ``2 * edge_columns + 2``); 0 by default (module docstring).
    min_column_pixels : int
        Matched pixels a column needs to give a footprint point.
    seen_through : SeenThroughParameters or None
        When the background showing between two obstacles keeps them apart, by ``max_gap_m`` in
        depth and ``max_chroma_distance`` in colour (:mod:`stereo_obstacles.seen_through`);
        ``None``: never.
    """

    max_gap_m: float = 0.3
    min_close_columns: int = 3
    min_close_fraction: float = 0.5
    max_chroma_distance: float = ColourSplitParameters.min_chroma_distance
    min_coincident_fraction: float = 0.75
    span_quantile: float = 0.25
    edge_columns: int = 0
    min_column_pixels: int = MIN_COLUMN_PIXELS
    seen_through: SeenThroughParameters | None = field(default_factory=SeenThroughParameters)

    def __post_init__(self) -> None:
        check_numbers(self, (("max_gap_m", 0.0, math.inf), ("min_close_fraction", 0.0, 1.0),
                             ("max_chroma_distance", 0.0, 400.0), ("min_coincident_fraction", 0.0, 1.0),
                             ("span_quantile", 0.0, 0.5)))
        check_integers(self, (("min_close_columns", 1, 10 ** 6), ("edge_columns", 0, 10 ** 6),
                              ("min_column_pixels", 1, 10 ** 6)))
        check_types(self, (("seen_through", SeenThroughParameters),), allow_none=True)


@dataclass(frozen=True)
class Footprint:
    """An obstacle's footprint points (``float64 (n, 2)``, ``X, Z``) and spans (``(m, 4)``,
    ``X near, Z near, X far, Z far``), metres, and the corners ``(X, Z)`` of the box holding both
    (``low`` at ``+inf`` and ``high`` at ``-inf`` when both are empty)."""

    points: np.ndarray
    spans: np.ndarray
    low: np.ndarray
    high: np.ndarray

    @classmethod
    def of(cls, xs: np.ndarray, disparities: np.ndarray, calibration: StereoCalibration,
           params: FootprintJoiningParameters) -> Footprint:
        """The footprint of the pixels in columns ``xs`` with these ``disparities`` (pixels)."""
        columns = {"edge_columns": params.edge_columns, "min_column_pixels": params.min_column_pixels}
        points = footprint(xs, disparities, calibration, **columns)
        spans = footprint_spans(xs, disparities, calibration, quantile=params.span_quantile, **columns)
        xz = np.concatenate([points, spans[:, :2], spans[:, 2:]])
        if len(xz) == 0:
            return cls(points, spans, np.full(2, np.inf), np.full(2, -np.inf))
        return cls(points, spans, xz.min(axis=0), xz.max(axis=0))


def _touch(first: Footprint, second: Footprint, params: FootprintJoiningParameters, *, one_colour: bool) -> bool:
    """Whether the footprints of two obstacles, of one colour or not, make them pieces of one
    object: they coincide (``min_close_columns`` and ``min_coincident_fraction`` of the spans of
    each lie within ``max_gap_m`` of the other's), or, of one colour, ``min_close_columns`` points
    of each lie within ``max_gap_m`` of the other footprint and so do ``min_close_fraction`` of the
    shorter one's."""
    # the points first: they cost less than the spans' segments
    return (one_colour and _close(first.points, second.points, params)) or _coincide(first.spans, second.spans, params)


def _coincide(first: np.ndarray, second: np.ndarray, params: FootprintJoiningParameters) -> bool:
    """Whether two obstacles' spans (``(n, 4)`` metres) coincide (:func:`_touch`)."""
    counts, lengths = close_spans(first, second, params.max_gap_m), (len(first), len(second))
    return (min(counts) >= params.min_close_columns
            and all(counts[k] >= params.min_coincident_fraction * lengths[k] for k in (0, 1)))


def _close(first: np.ndarray, second: np.ndarray, params: FootprintJoiningParameters) -> bool:
    """Whether two obstacles' footprint points (``(n, 2)`` metres) touch as one colour's must
    (:func:`_touch`)."""
    counts, lengths = close_points(first, second, params.max_gap_m), (len(first), len(second))
    shorter = [k for k in (0, 1) if lengths[k] == min(lengths)]          # both, when they are as long
    return (min(counts) >= params.min_close_columns
            and all(counts[k] >= params.min_close_fraction * lengths[k] for k in shorter))


def pieces_of_one_object(obstacles: ObstacleList, disparity: np.ndarray, colour: ColourCue,
                         calibration: StereoCalibration,
                         params: FootprintJoiningParameters = FootprintJoiningParameters()) -> list[tuple[int, int]]:
    """The pairs ``(host, piece)`` of obstacle ids to join (module docstring): each piece once.

    Parameters
    ----------
    obstacles
        The obstacles, whose ``id_map`` (``int (H, W)``, 0: none) says which pixels each covers.
    disparity
        ``float32 (H, W)`` disparity they were measured on, pixels, NaN where unmatched.
    colour
        The left image's chroma and phase-1 colour verdict, ``(H, W)`` as the id map.
    calibration
        The rig, for the footprints in metres.
    params
        When to join.

    Raises
    ------
    InvalidInputError
        A disparity or colour of another height and width than the id map, a colour that is not
        a :class:`~stereo_obstacles.colour_split.ColourCue`, or no calibration.
    """
    if not isinstance(colour, ColourCue):
        raise InvalidInputError(f"colour must be a ColourCue (chroma and phase-1 colour verdict), got "
                                f"{type(colour).__name__}")
    id_map, disparity, chroma = np.asarray(obstacles.id_map), np.asarray(disparity), colour.chroma
    if disparity.shape != id_map.shape or chroma.shape[:2] != id_map.shape:
        raise InvalidInputError(f"disparity {disparity.shape} and chroma {chroma.shape} must be (H, W) and "
                                f"(H, W, 2) for the id map's (H, W) = {id_map.shape}")
    if not isinstance(calibration, StereoCalibration):
        raise InvalidInputError(f"calibration must be a StereoCalibration (footprints are in metres), got "
                                f"{type(calibration).__name__}")
    pixels, colours = {}, {}
    for o in obstacles.obstacles:
        pixels[o.id] = obstacle_pixels(o, id_map)
        colours[o.id] = np.median(chroma[pixels[o.id]], axis=0)
    prints: dict[int, Footprint] = {}

    def footprint_of(k: int) -> Footprint:
        if k not in prints:
            ys, xs = pixels[k]
            prints[k] = Footprint.of(xs, disparity[ys, xs], calibration, params)
        return prints[k]

    ids = sorted(pixels)
    touching: dict[int, set[int]] = {k: set() for k in ids}
    for i, a in enumerate(ids):
        for b in ids[i + 1:]:
            first, second = footprint_of(a), footprint_of(b)
            # bounding boxes farther apart than the gap in X or Z: nothing can touch (a cheap first test)
            if np.any(np.maximum(first.low, second.low) - np.minimum(first.high, second.high) > params.max_gap_m):
                continue
            one_colour = math.dist(colours[a], colours[b]) <= params.max_chroma_distance
            if _touch(first, second, params, one_colour=one_colour) and not (
                    params.seen_through is not None
                    and background_between(pixels[a], pixels[b], disparity, colour, (colours[a], colours[b]),
                                           calibration, params.max_gap_m, params.max_chroma_distance,
                                           params.seen_through)):
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
