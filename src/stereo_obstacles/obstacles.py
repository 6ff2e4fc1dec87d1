"""Obstacles as objects: distance, image box, 3-D position and size, height above the ground.

Phase 3 of the paper turns obstacle pixels into depths; users need objects. Obstacle pixels
with a disparity are grouped (:mod:`stereo_obstacles.obstacle_grouping`) and each group is
measured here. With a calibration every length is in metres in the rectified left camera
frame (x right, y down, z forward); without one, only pixels and disparities are reported.

Distance of an obstacle is that of its near face (:mod:`stereo_obstacles.near_face`): a low
percentile of its patches' median depths (each the median of its neighbourhood's), or a plane
through them for a face slanted in depth. Height above the ground uses the ground plane fitted
in (x, y, disparity) space, converted to a 3-D plane; objects of which fewer than
``min_standing_fraction`` of the pixels stand more than ``flat_tolerance_m`` above that plane
are rejected as flat (markings, puddles), and the rejection is reported with its reason.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from stereo_obstacles import quantiles
from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.direction_scan import MIN_SECTOR_DEG, DirectionScan, direction_scan
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import check_integers, check_numbers, check_positive, check_types
from stereo_obstacles.ground_plane import GroundPlane, height_above_ground_m, raised_pixels
from stereo_obstacles.near_face import (DISTANCE_PATCH_PX, MAX_NEIGHBOURHOOD_PATCHES, SlantedFaceParameters,
                                        near_face_depth)

QUARTILES = (25.0, 50.0, 75.0)
"""Percentiles of a group's disparities: its reported disparity (median) and spread."""

EXTENT_PERCENTILES = (1.0, 99.0)
"""Percentiles of the pixels' 3-D coordinates taken as an obstacle's extent (robust min/max)."""


@dataclass(frozen=True)
class ObstacleParameters:
    """How groups of obstacle pixels become reported obstacles.

    Attributes
    ----------
    flat_tolerance_m : float
        Pixels less than this high above the ground plane lie on it (needs a calibration
        and a ground plane).
    flat_tolerance_px : float
        The same test without a calibration, in disparity above the ground plane (pixels).
    min_standing_fraction : float
        Fraction of a group's pixels that must stand above the ground by more than the flat
        tolerance; fewer, and the group is flat on the ground (a marking, a puddle, a shadow).
    max_distance_m : float
        Groups farther than this are not reported (depth error grows as Z**2); the pipeline
        leaves the pixels farther than this out before it groups them
        (:func:`stereo_obstacles.pipeline.detect`).
    corridor_width_m : float
        Width of the walking corridor straight ahead for :func:`corridor_summary`.
    distance_percentile : float
        Percentile of the obstacle's patch depths reported as its distance (0: the nearest).
    distance_min_patch_pixels : int
        Patches with fewer of the obstacle's pixels do not count for its distance (unless no
        patch has that many); of the ``DISTANCE_PATCH_PX ** 2`` = 64 pixels of a patch.
    distance_neighbourhood_patches : int
        Each counting patch's depth is the median of the counting patches' median depths within
        this many patches of it in column and in row, itself included (1: 3 x 3 patches; 0: its
        own median alone; :mod:`stereo_obstacles.near_face`).
    slanted_face : SlantedFaceParameters or None
        When a face slanted in depth is measured by a plane through its patches instead of the
        percentile (:mod:`stereo_obstacles.near_face`); ``None`` always takes the percentile.
    scan_sector_deg : float
        Width in degrees of bearing of the sectors of the free-range scan
        (:mod:`stereo_obstacles.direction_scan`; needs a calibration).
    scan_min_pixels : int
        Pixels of known depth an obstacle needs in a sector to count in the scan there.
    scan_percentile : float
        An obstacle's range in a sector is this percentile of its pixels' horizontal ranges there.
    min_disparity_px : float
        Without a calibration, groups whose median disparity is below this are at infinity (or
        the two images are the same) and are not reported; with one, ``max_distance_m`` decides.
    """

    flat_tolerance_m: float = 0.08
    flat_tolerance_px: float = 1.0
    min_standing_fraction: float = 0.3
    max_distance_m: float = 30.0
    corridor_width_m: float = 1.0
    distance_percentile: float = 5.0
    distance_min_patch_pixels: int = 16
    distance_neighbourhood_patches: int = 1
    min_disparity_px: float = 0.5
    slanted_face: SlantedFaceParameters | None = field(default_factory=SlantedFaceParameters)
    scan_sector_deg: float = 1.0
    scan_min_pixels: int = 10
    scan_percentile: float = 10.0

    def __post_init__(self) -> None:
        check_numbers(self, (("distance_percentile", 0.0, 100.0), ("scan_percentile", 0.0, 100.0),
                             ("min_standing_fraction", 0.0, 1.0),
                             ("min_disparity_px", 0.0, math.inf), ("scan_sector_deg", MIN_SECTOR_DEG, 180.0)))
        check_integers(self, (("distance_min_patch_pixels", 1, DISTANCE_PATCH_PX ** 2),
                              ("distance_neighbourhood_patches", 0, MAX_NEIGHBOURHOOD_PATCHES),
                              ("scan_min_pixels", 1, 10 ** 9)))
        check_positive(self, ("flat_tolerance_m", "flat_tolerance_px", "max_distance_m", "corridor_width_m"))
        check_types(self, (("slanted_face", SlantedFaceParameters),), allow_none=True)


@dataclass(frozen=True)
class Obstacle:
    """One detected obstacle. Lengths in metres (``None`` without a calibration), in the rectified
    left camera frame: ``X`` right, ``Y`` down, ``Z`` forward along the optical axis.

    ``distance_m`` is the depth ``Z`` of its near face (a low percentile of its patches' depths,
    :mod:`stereo_obstacles.near_face`), not the range ``sqrt(X**2 + Z**2)`` (the scan's
    ``ranges_m`` are ranges). ``disparity_px`` is the median disparity of the pixels it is measured
    on. ``box_px`` is ``(x0, y0, x1, y1)``, inclusive-exclusive pixel bounds in the left image;
    ``centre_m`` the median 3-D point ``(X, Y, Z)`` of its pixels standing above the ground;
    ``lateral_extent_m`` the 1st and 99th percentiles of ``X`` and ``width_m`` their difference;
    ``height_m`` its visible height (1st to 99th percentile of ``Y``); ``height_above_ground_m`` the
    99th percentile of its pixels' heights above the ground plane, its top (``None`` without a
    plane); ``confidence`` in [0, 1] grows with the number of matched pixels and their depth
    agreement. The fields of ``obstacles.json`` are these: ``docs/pipeline.md``. An obstacle
    joined from pieces has its ``distance_m`` kept no farther than its largest piece's
    (:mod:`stereo_obstacles.obstacle_joining`).
    """

    id: int
    box_px: tuple[int, int, int, int]
    pixel_count: int
    disparity_px: float
    confidence: float
    distance_m: float | None = None
    centre_m: tuple[float, float, float] | None = None
    lateral_extent_m: tuple[float, float] | None = None
    width_m: float | None = None
    height_m: float | None = None
    height_above_ground_m: float | None = None


@dataclass(frozen=True)
class RejectedGroup:
    """A group of obstacle pixels that was not reported, and why."""

    box_px: tuple[int, int, int, int]
    pixel_count: int
    reason: str


@dataclass(frozen=True)
class CorridorSummary:
    """The nearest obstacle in a corridor straight ahead, and the free distance before it.

    ``nearest_obstacle_id`` is ``None`` and ``free_distance_m`` is ``None`` when nothing was
    found in the corridor (the free distance is then unknown beyond the measured range).
    """

    width_m: float
    nearest_obstacle_id: int | None
    free_distance_m: float | None


@dataclass(frozen=True)
class ObstacleList:
    """Obstacles nearest first, the groups rejected, and (if calibrated) the corridor summary and
    the free range per direction.

    ``id_map`` is ``int32 (H, W)``: the id of the obstacle each pixel belongs to, 0 for none.
    """

    obstacles: tuple[Obstacle, ...]
    id_map: np.ndarray
    rejected: tuple[RejectedGroup, ...] = field(default_factory=tuple)
    corridor: CorridorSummary | None = None
    scan: DirectionScan | None = None


def standing_pixels(candidates: np.ndarray, disparity: np.ndarray, ground: GroundPlane | None,
                    calibration: StereoCalibration | None,
                    params: ObstacleParameters = ObstacleParameters(), *,
                    min_excess_px: float | np.ndarray = 0.0) -> np.ndarray:
    """Candidate pixels with a disparity that stand above the ground by the flat tolerance or more
    (and, with a calibration, whose disparity exceeds the plane's by ``min_excess_px`` or more,
    one number or ``float (H, W)`` per pixel: far away, disparity noise alone is a large height).

    Grouping only standing pixels keeps two objects from being chained together through the
    ground between them; the remaining (flat) candidates can be grouped separately to report
    markings and puddles. Without a ground plane every candidate with a disparity stands.

    Returns
    -------
    numpy.ndarray
        ``bool (H, W)``.
    """
    d = np.asarray(disparity, dtype=np.float32)
    if ground is None:
        return np.asarray(candidates, dtype=bool) & np.isfinite(d)
    if calibration is None:
        return raised_pixels(ground, d, candidates, None, min_excess_px=params.flat_tolerance_px)
    return raised_pixels(ground, d, candidates, calibration, min_height_m=params.flat_tolerance_m,
                         min_excess_px=min_excess_px)


def obstacle_pixels(obstacle: Obstacle, id_map: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rows and columns (``int64 (n,)``) of the obstacle's pixels in ``id_map`` (``int (H, W)``, as
    :attr:`ObstacleList.id_map`), found within its box."""
    x0, y0, x1, y1 = obstacle.box_px
    ys, xs = np.nonzero(id_map[y0:y1, x0:x1] == obstacle.id)
    return ys + y0, xs + x0


def _box(xs: np.ndarray, ys: np.ndarray) -> tuple[int, int, int, int]:
    return int(xs.min()), int(ys.min()), int(xs.max()) + 1, int(ys.max()) + 1


def _confidence(pixel_count: int, quartiles: tuple[float, float, float]) -> float:
    """More pixels and a tighter disparity spread (``quartiles``: 25th, 50th, 75th percentile
    of the disparities) give more confidence (0..1)."""
    size_term = 1.0 - math.exp(-pixel_count / 300.0)
    spread = float(quartiles[2] - quartiles[0])
    agreement = 1.0 / (1.0 + spread / max(1.0, 0.1 * float(quartiles[1])))
    return round(size_term * agreement, 3)


def measure_obstacles(groups: np.ndarray, disparity: np.ndarray,
                      calibration: StereoCalibration | None, ground: GroundPlane | None,
                      params: ObstacleParameters = ObstacleParameters(), *, with_scan: bool = True) -> ObstacleList:
    """Measure each group of obstacle pixels; reject flat and far ones; sort nearest first.

    Parameters
    ----------
    groups
        ``int (H, W)`` group number per pixel, 0 for none, numbers need not be contiguous (from
        :func:`stereo_obstacles.obstacle_grouping.group_obstacle_pixels`).
    disparity
        ``float32 (H, W)`` disparity in pixels, NaN where unmatched.
    calibration
        Rectified calibration, or ``None`` to stay in pixels and disparities.
    ground
        The ground plane in disparity space, or ``None`` when it could not be fitted (then
        nothing is rejected as flat and heights above the ground are not reported).
    params
        Thresholds.
    with_scan
        Whether to measure the free range per direction (with a calibration; the pipeline
        measures its scan once the obstacles are final, and its flat groups need none).
    """
    measured = measure_groups(groups, disparity, calibration, ground, params)
    return list_obstacles(measured, groups, disparity, calibration, params, with_scan=with_scan)


def measure_groups(groups: np.ndarray, disparity: np.ndarray, calibration: StereoCalibration | None,
                   ground: GroundPlane | None,
                   params: ObstacleParameters = ObstacleParameters()) -> dict[int, Obstacle | RejectedGroup]:
    """The first half of :func:`measure_obstacles` (same parameters): each group's obstacle (its
    ``id`` still 0) or the reason it is rejected, by group number, in increasing order. A caller
    may leave some groups out before :func:`list_obstacles` lists the rest (the measure of one
    group does not depend on the others)."""
    groups = np.asarray(groups)
    d = np.asarray(disparity, dtype=np.float32)
    if groups.shape != d.shape or d.ndim != 2:
        raise InvalidInputError(f"groups {groups.shape} and disparity {d.shape} must be the same 2-D shape")
    flat = groups.ravel()
    grouped = np.flatnonzero(flat)  # sort only the grouped pixels (a few % of the image)
    order = grouped[np.argsort(flat[grouped], kind="stable")]
    bounds = np.searchsorted(flat[order], np.arange(1, int(flat.max(initial=0)) + 2))
    w = d.shape[1]
    measured: dict[int, Obstacle | RejectedGroup] = {}
    for group in range(1, len(bounds)):
        index = order[bounds[group - 1]:bounds[group]]
        if index.size == 0:  # group numbers need not be contiguous
            continue
        ys, xs = np.divmod(index, w)
        measured[group] = _measure_group(xs, ys, d[ys, xs].astype(np.float64), calibration, ground, params)
    return measured


def measure_without(taken_out: np.ndarray, groups: np.ndarray, measured: dict[int, Obstacle | RejectedGroup],
                    disparity: np.ndarray, calibration: StereoCalibration | None, ground: GroundPlane | None,
                    params: ObstacleParameters = ObstacleParameters()
                    ) -> tuple[np.ndarray, dict[int, Obstacle | RejectedGroup]]:
    """``groups`` with the pixels ``taken_out`` (``bool (H, W)``) in no group, and ``measured``
    (:func:`measure_groups` of ``groups``, the other parameters as it takes them) with only the
    groups that lost pixels measured again, in group order as :func:`measure_groups` gives them;
    a group that lost every pixel is left out."""
    groups = np.asarray(groups)
    touched = np.unique(groups[taken_out])
    touched = touched[touched > 0]
    groups = np.where(taken_out, 0, groups).astype(groups.dtype, copy=False)
    again = measure_groups(np.where(np.isin(groups, touched), groups, 0), disparity, calibration, ground, params)
    kept = {group: outcome for group, outcome in measured.items() if group not in set(touched.tolist())}
    return groups, dict(sorted({**kept, **again}.items()))


def list_obstacles(measured: dict[int, Obstacle | RejectedGroup], groups: np.ndarray, disparity: np.ndarray,
                   calibration: StereoCalibration | None, params: ObstacleParameters = ObstacleParameters(), *,
                   with_scan: bool = True) -> ObstacleList:
    """The second half of :func:`measure_obstacles`: the obstacles of ``measured`` (from
    :func:`measure_groups` of ``groups``, or part of it) numbered nearest first, their id map,
    the rejections in group order, and with a calibration the corridor (and the scan when
    ``with_scan``)."""
    groups = np.asarray(groups)
    if groups.ndim != 2 or np.shape(disparity) != groups.shape:
        raise InvalidInputError(f"groups {groups.shape} and disparity {np.shape(disparity)} must be the same 2-D shape")
    n_numbers = int(groups.max(initial=0)) + 1
    if any(not (isinstance(group, (int, np.integer)) and 1 <= group < n_numbers) for group in measured):
        raise InvalidInputError(f"measured: expected the numbers of groups in 1..{n_numbers - 1}, got "
                                f"{sorted(measured)}")
    kept = [(outcome, group) for group, outcome in measured.items() if isinstance(outcome, Obstacle)]
    rejected = tuple(outcome for outcome in measured.values() if not isinstance(outcome, Obstacle))
    kept.sort(key=lambda pair: (pair[0].distance_m if pair[0].distance_m is not None else math.inf,
                                -pair[0].disparity_px))
    numbered = tuple(Obstacle(**{**o.__dict__, "id": i + 1}) for i, (o, _) in enumerate(kept))
    group_to_id = np.zeros(n_numbers, dtype=np.int32)
    for i, (_, group) in enumerate(kept):
        group_to_id[group] = i + 1
    id_map = np.take(group_to_id, groups, mode="clip")     # one pass; negative numbers clipped to "none"
    if calibration is None:
        return ObstacleList(obstacles=numbered, id_map=id_map, rejected=rejected)
    return ObstacleList(obstacles=numbered, id_map=id_map, rejected=rejected,
                        corridor=corridor_summary(numbered, params.corridor_width_m),
                        scan=obstacle_scan(id_map, np.asarray(disparity, dtype=np.float32), calibration, params)
                        if with_scan else None)


def obstacle_scan(id_map: np.ndarray, disparity: np.ndarray, calibration: StereoCalibration,
                  params: ObstacleParameters = ObstacleParameters()) -> DirectionScan:
    """The free range per direction of the obstacles of ``id_map`` (``int (H, W)``, 0: none),
    at the disparities ``disparity`` (``float32 (H, W)`` pixels, NaN: none), with the sectors,
    pixel count and percentile of ``params`` (:mod:`stereo_obstacles.direction_scan`)."""
    return direction_scan(id_map, disparity, calibration, sector_deg=params.scan_sector_deg,
                          min_pixels=params.scan_min_pixels, percentile=params.scan_percentile)


def _flat(box, count: int, above: float, unit: str, tolerance: float) -> RejectedGroup:
    """The rejection of a group not standing on the ground plane: ``above`` is its 99th
    percentile height above the plane. A group wholly below the plane by more than the
    ``tolerance`` is not a marking: the plane does not describe that part of the scene."""
    if above < -tolerance:
        return RejectedGroup(box, count, f"below the fitted ground plane (at least {-above:.2f} {unit} under it): "
                                         f"the plane does not fit this part of the scene")
    return RejectedGroup(box, count, f"flat on the ground plane (a marking or puddle): at most {above:.2f} {unit} above it")


def _measure_group(xs: np.ndarray, ys: np.ndarray, disparities: np.ndarray,
                   calibration: StereoCalibration | None, ground: GroundPlane | None,
                   params: ObstacleParameters) -> Obstacle | RejectedGroup:
    """Measure one group of pixels (columns ``xs``, rows ``ys``) or say why it is rejected.

    With a ground plane, only the group's *standing* pixels (above the ground by more than
    the flat tolerance) are measured: ground pixels at an object's foot would otherwise pull
    its distance nearer. A group with too few standing pixels is flat on the ground.
    """
    box, count = _box(xs, ys), int(len(xs))
    if calibration is None:
        if ground is not None:
            above_px = disparities - ground.disparity_at(xs, ys)
            standing = above_px >= params.flat_tolerance_px
            if standing.mean() < params.min_standing_fraction:
                return _flat(box, count, quantiles.percentile(above_px, EXTENT_PERCENTILES[1]), "px",
                             params.flat_tolerance_px)
            disparities = disparities[standing]
        quartiles = _quartiles(disparities)
        if quartiles[1] < params.min_disparity_px:
            return RejectedGroup(box, count, f"at infinity: median disparity {quartiles[1]:.2f} px (below "
                                             f"{params.min_disparity_px:g} px)")
        return Obstacle(id=0, box_px=box, pixel_count=count, disparity_px=round(float(quartiles[1]), 3),
                        confidence=_confidence(count, quartiles))
    positive = disparities + calibration.doffs_px > 0
    if not positive.any():
        return RejectedGroup(box, count, "no valid depth (disparity + doffs <= 0)")
    xs, ys, disparities = xs[positive], ys[positive], disparities[positive]
    z = calibration.focal_baseline_px_m / (disparities + calibration.doffs_px)
    points = np.stack([(xs - calibration.cx_px) * z / calibration.focal_px,
                       (ys - calibration.cy_px) * z / calibration.focal_px, z], axis=-1)
    height_above = None
    if ground is not None:
        heights = height_above_ground_m(ground, points, calibration)
        standing = heights >= params.flat_tolerance_m
        high = quantiles.percentile(heights, EXTENT_PERCENTILES[1])
        if standing.mean() < params.min_standing_fraction:
            return _flat(box, count, high, "m", params.flat_tolerance_m)
        height_above = round(high, 3)
        points, disparities = points[standing], disparities[standing]
    distance = near_face_depth(xs[standing] if ground is not None else xs,
                               ys[standing] if ground is not None else ys, points[:, 2],
                               percentile=params.distance_percentile, min_patch_pixels=params.distance_min_patch_pixels,
                               neighbourhood_patches=params.distance_neighbourhood_patches,
                               focal_baseline_px_m=calibration.focal_baseline_px_m, slanted_face=params.slanted_face)
    if distance > params.max_distance_m:
        return RejectedGroup(box, count, f"farther than {params.max_distance_m:g} m ({distance:.1f} m)")
    # each coordinate sorted once for its extent and median (np.percentile costs 0.1-0.2 ms a call)
    along = [np.sort(points[:, k]) for k in range(3)]
    x_lo, x_hi = (quantiles.percentile_of_sorted(along[0], q) for q in EXTENT_PERCENTILES)
    y_lo, y_hi = (quantiles.percentile_of_sorted(along[1], q) for q in EXTENT_PERCENTILES)
    quartiles = _quartiles(disparities)
    return Obstacle(id=0, box_px=box, pixel_count=count, disparity_px=round(float(quartiles[1]), 3),
                    confidence=_confidence(count, quartiles), distance_m=round(distance, 3),
                    centre_m=tuple(round(quantiles.median_of_sorted(v), 3) for v in along),
                    lateral_extent_m=(round(float(x_lo), 3), round(float(x_hi), 3)),
                    width_m=round(float(x_hi - x_lo), 3), height_m=round(float(y_hi - y_lo), 3),
                    height_above_ground_m=height_above)


def _quartiles(disparities: np.ndarray) -> tuple[float, float, float]:
    """The :data:`QUARTILES` of a group's disparities (``float64``), as ``np.percentile`` gives them."""
    ordered = np.sort(disparities)
    return tuple(quantiles.percentile_of_sorted(ordered, q) for q in QUARTILES)


def corridor_summary(obstacles: tuple[Obstacle, ...], width_m: float) -> CorridorSummary:
    """The nearest obstacle whose lateral extent overlaps ``[-width_m / 2, width_m / 2]``.

    The corridor runs straight ahead along the left camera's optical axis.
    """
    half = width_m / 2.0
    for o in sorted((o for o in obstacles if o.lateral_extent_m is not None), key=lambda o: o.distance_m):
        lo, hi = o.lateral_extent_m
        if hi >= -half and lo <= half:
            return CorridorSummary(width_m=width_m, nearest_obstacle_id=o.id, free_distance_m=o.distance_m)
    return CorridorSummary(width_m=width_m, nearest_obstacle_id=None, free_distance_m=None)
