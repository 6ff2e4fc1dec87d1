"""Filling the textureless faces the matcher leaves empty, for the free range per direction.

A face of dark or dull paint can have so little texture (a window standard deviation under the
matcher's ``min_std`` of 1 grey level) that the matcher calls it flat and matches only its
outline: the obstacle is found at the right distance, but as a thin piece, and the free range
per direction (:mod:`stereo_obstacles.direction_scan`) sees through its middle to what stands
behind it (``docs/pipeline.md``, "Free range per direction"). Phase 1 still labels such a face
obstacle by its colour; what it lacks is a disparity.

A *textureless region* is what has no disparity and belongs to no obstacle in a 4-connected set
of pixels that phase 1 calls obstacle and that lie off the left image's edges (Canny on a copy of
half the size, dilated by one pixel: a textured surface falls apart into small pieces), when at
least ``min_area_px`` pixels remain. Along each
row, a run of the region is *bracketed* when an obstacle pixel with a disparity lies within
``reach_px`` on both sides and the two disparities agree (``max(end_tolerance_px,
end_tolerance_fraction * d)``): one surface continues between them. A run whose ends disagree is
bracketed too when each stands on the ground at its own depth, as the ends of a face slanted in
depth do: the region meets the ground below at least ``min_contact_fraction`` of the run's
columns, along the straight line in disparity (within ``slant_tolerance_px`` in
:data:`STRAIGHT_SHARE` of those columns) between its means under the run's first and under its
last :data:`END_CONTACT_COLUMNS` columns, and each end agrees with the mean at its side as two
ends must agree. The bottom of a plane standing on the ground is a straight line in the image,
its disparity linear along it; two objects of one colour at two depths meet the ground with a
step (``docs/pipeline.md``, "Textureless faces slanted in depth", session 43). A region is
filled when

* at least ``min_bracketed_fraction`` of its rows have a bracketed run, and
* it stands on the ground at the depth of its outline: walking down from its lowest pixel in
  each column (at most ``max_walk_px`` rows, through whatever lies below it) to the first pixel
  phase 1 calls ground or shadow, at least ``min_contact_fraction`` of its columns meet the
  ground, and the ground plane's disparity there (median) agrees with the bracketing
  disparities (median) within ``max(contact_tolerance_px, contact_tolerance_fraction * d)``.

Of a filled region, only the bracketed runs whose nearer end agrees in the same way with the
ground the region meets in the run's own columns (their mean), or that stand on the ground at
both ends as above, are filled: a run between the edges of two nearer objects, over a face that
stands behind them, meets the ground behind them.

The sky between two poles is textureless and labelled obstacle too, and bracketed by the poles,
but it meets the ground at the horizon, far behind them: the contact test keeps it empty.

Each bracketed run of a filled region takes the disparities interpolated linearly between its
two ends and the id of the nearer end's obstacle. The scan is
measured on the filled maps, and :func:`widen_obstacles` widens each obstacle's box, lateral
extent and width to its filled pixels; its distance, disparity, centre, size in height, pixel
count and confidence stay those of its matched pixels.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import cv2
import numpy as np

from stereo_obstacles._textureless_fill_kernel import (bracketed_runs_kernel, empty_regions_kernel,
                                                       ground_contacts_kernel)
from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import check_integers, check_numbers, is_finite_real, plain_numbers
from stereo_obstacles.ground_plane import GroundPlane
from stereo_obstacles.labels import Label
from stereo_obstacles.obstacles import EXTENT_PERCENTILES, ObstacleList, corridor_summary


@dataclass(frozen=True)
class TexturelessFillParameters:
    """When a textureless region is filled (module docstring). Lengths in pixels; disparity
    tolerances in pixels or as a fraction of the disparity.

    ``edge_thresholds`` are Canny's two thresholds on the left image's grey levels (0-255);
    ``slant_tolerance_px`` how far (pixels of disparity) the ground a run meets may lie from the
    straight line between the ground under its two ends, for a face slanted in depth.
    """

    min_area_px: int = 150
    reach_px: int = 6
    end_tolerance_px: float = 1.0
    end_tolerance_fraction: float = 0.1
    min_bracketed_fraction: float = 0.5
    contact_tolerance_px: float = 1.0
    contact_tolerance_fraction: float = 0.08
    min_contact_fraction: float = 0.5
    max_walk_px: int = 40
    edge_thresholds: tuple[float, float] = (20.0, 60.0)
    slant_tolerance_px: float = 0.3

    def __post_init__(self) -> None:
        plain_numbers(self)                      # NumPy scalars as Python numbers (JSON-ready)
        check_integers(self, (("min_area_px", 1, 10 ** 9), ("reach_px", 1, 1000), ("max_walk_px", 1, 10 ** 5)))
        check_numbers(self, (("end_tolerance_px", 0.0, 1000.0), ("end_tolerance_fraction", 0.0, 1.0),
                             ("min_bracketed_fraction", 0.0, 1.0), ("contact_tolerance_px", 0.0, 1000.0),
                             ("contact_tolerance_fraction", 0.0, 1.0), ("min_contact_fraction", 0.0, 1.0),
                             ("slant_tolerance_px", 0.0, 1000.0)))
        pair = self.edge_thresholds
        if not (isinstance(pair, tuple) and len(pair) == 2 and all(is_finite_real(v) for v in pair)
                and 0 <= pair[0] <= pair[1]):
            raise InvalidInputError(f"edge_thresholds must be two grey levels, low <= high, got {pair!r}")


def _agree(a: np.ndarray | float, b: np.ndarray | float, tolerance_px: float, fraction: float) -> np.ndarray:
    """Whether disparities ``a`` and ``b`` lie within ``max(tolerance_px, fraction * max(a, b))``."""
    return np.abs(a - b) <= np.maximum(tolerance_px, fraction * np.maximum(a, b))


def textureless_candidates(labels: np.ndarray, left_rgb: np.ndarray,
                           params: TexturelessFillParameters = TexturelessFillParameters()) -> np.ndarray:
    """``int32 (H, W)``: the 4-connected sets of pixels that phase 1 calls obstacle (``labels``,
    ``uint8 (H, W)``) off the edges of the left image (``uint8 (H, W, 3)`` RGB), numbered from 1
    (0: none); sets of fewer than ``min_area_px`` pixels are left out. Found on copies of half
    the size (a fifth of the time; the regions that matter are hundreds of pixels). Needs no
    disparity, so the pipeline finds them beside the matcher; :func:`fill_textureless` keeps their
    pixels without a disparity."""
    labels = np.asarray(labels)
    left_rgb = np.asarray(left_rgb)
    if left_rgb.dtype != np.uint8 or left_rgb.ndim != 3 or left_rgb.shape[2] != 3 or 0 in left_rgb.shape:
        raise InvalidInputError(f"the left image must be uint8 RGB (H, W, 3), not empty; got {left_rgb.dtype} "
                                f"{left_rgb.shape}")
    if labels.shape != left_rgb.shape[:2]:
        raise InvalidInputError(f"labels {labels.shape} and the left image {left_rgb.shape[:2]} must have one "
                                f"height and width")
    h, w = labels.shape
    half = (max(1, w // 2), max(1, h // 2))
    grey = cv2.resize(cv2.cvtColor(np.ascontiguousarray(left_rgb), cv2.COLOR_RGB2GRAY), half,
                      interpolation=cv2.INTER_AREA)
    edges = cv2.dilate(cv2.Canny(grey, *params.edge_thresholds), np.ones((3, 3), np.uint8))
    obstacle = (labels == Label.OBSTACLE.value).astype(np.uint8)
    plain = cv2.resize(obstacle, half, interpolation=cv2.INTER_NEAREST) & (edges == 0)
    n, components, stats, _ = cv2.connectedComponentsWithStats(plain.astype(np.uint8), connectivity=4,
                                                               ltype=cv2.CV_32S)
    large = stats[:, cv2.CC_STAT_AREA] * (w * h) / (half[0] * half[1]) >= params.min_area_px
    large[0] = False
    renumber = np.zeros(n, np.int32)
    renumber[large] = np.arange(1, int(large.sum()) + 1, dtype=np.int32)
    return cv2.resize(renumber[components], (w, h), interpolation=cv2.INTER_NEAREST) * obstacle


@dataclass(frozen=True)
class _GroundMet:
    """Where each textureless region meets the ground, column by column: ``at[k, x]`` (``float64
    (n_regions + 1, W)``) is the ground plane's disparity where region ``k`` meets it below column
    ``x`` (NaN: it meets none there), with its cumulative sums and counts along the columns."""

    at: np.ndarray
    sums: np.ndarray
    counts: np.ndarray

    @classmethod
    def of(cls, contacts: np.ndarray, contact_d: np.ndarray, n_regions: int, width: int) -> _GroundMet:
        """From the contacts (rows ``(region, x, y)``, one per region and column) and their
        disparities ``contact_d``."""
        at = np.full((n_regions + 1, width), np.nan)
        at[contacts[:, 0], contacts[:, 1]] = contact_d
        met = np.isfinite(at)
        zero = np.zeros((n_regions + 1, 1))
        return cls(at, np.hstack([zero, np.cumsum(np.where(met, at, 0.0), axis=1)]),
                   np.hstack([zero, np.cumsum(met, axis=1)]))

    def mean(self, region: np.ndarray, x0: np.ndarray, x1: np.ndarray) -> np.ndarray:
        """``float64 (n,)``: the mean ground disparity where region ``region[i]`` meets the ground in
        columns ``x0[i]..x1[i]``; NaN where it meets none there."""
        n = self.counts[region, x1 + 1] - self.counts[region, x0]
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(n > 0, (self.sums[region, x1 + 1] - self.sums[region, x0]) / n, np.nan)


END_CONTACT_COLUMNS = 3
"""A run's end meets the ground where the region does in the run's first (or last) this many columns."""

STRAIGHT_SHARE = 0.9
"""A run meets the ground along the straight line between its ends in at least this share of its
columns that meet the ground."""


@dataclass(frozen=True)
class BracketedRuns:
    """The runs of the textureless regions that :func:`fill_textureless` fills: in row ``y``,
    columns ``x0..x1`` (inclusive), bracketed by obstacle pixels at columns ``xl`` (left) and
    ``xr`` (right) of disparities ``d_left`` and ``d_right``. ``contact_left`` and
    ``contact_right`` are the ground disparities where the region meets the ground in the run's
    first and last :data:`END_CONTACT_COLUMNS` columns (their means), given only when the ground
    it meets along the run lies on the straight line between them (:func:`_end_contacts`), NaN
    otherwise; ``stepped`` says that a step between two levels fits that ground better than a
    line (two objects side by side at two depths, or a face that bends; ``False`` for a run
    without contacts). Each field is an array of one value per run (``int64``; the disparities
    ``float32``, the contacts ``float64``, pixels; ``stepped`` ``bool``)."""

    y: np.ndarray
    x0: np.ndarray
    x1: np.ndarray
    xl: np.ndarray
    xr: np.ndarray
    d_left: np.ndarray
    d_right: np.ndarray
    contact_left: np.ndarray
    contact_right: np.ndarray
    stepped: np.ndarray


def bracketed_runs(candidates: np.ndarray, id_map: np.ndarray, disparity: np.ndarray, labels: np.ndarray,
                   ground: GroundPlane, params: TexturelessFillParameters = TexturelessFillParameters()
                   ) -> BracketedRuns | None:
    """The runs of the textureless regions to fill (module docstring), ``None`` when there are
    none. The arguments are :func:`fill_textureless`'s."""
    ids, d = _checked_maps(candidates, id_map, disparity, labels)
    regions = empty_regions_kernel(np.ascontiguousarray(candidates, dtype=np.int32), ids, d, params.min_area_px)
    n_regions = int(regions.max(initial=0))
    if n_regions == 0:
        return None
    y, x0, x1, region, xl, xr = bracketed_runs_kernel(regions, ids, d, params.reach_px).T
    both_ends = (xl >= 0) & (xr >= 0)
    d_left, d_right = d[y, np.maximum(xl, 0)], d[y, np.maximum(xr, 0)]
    contacts, columns = ground_contacts_kernel(regions, n_regions, np.ascontiguousarray(labels, dtype=np.uint8),
                                               Label.GROUND.value, Label.SHADOW.value, params.max_walk_px)
    contact_d = ground.disparity_at(contacts[:, 1].astype(np.float64), contacts[:, 2].astype(np.float64))
    met = _GroundMet.of(contacts, contact_d, n_regions, ids.shape[1])
    contact_left, contact_right, stepped = _end_contacts(met, region, x0, x1, both_ends, params)

    def agree_as_ends(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return _agree(a, b, params.end_tolerance_px, params.end_tolerance_fraction)

    level = agree_as_ends(d_left, d_right)
    # a face slanted in depth: its ends at two depths, each standing on the ground at its own
    slanted = ~level & agree_as_ends(d_left, contact_left) & agree_as_ends(d_right, contact_right)
    bracketed = both_ends & (level | slanted)
    standing = _standing_regions(region * ids.shape[0] + y, bracketed, d_left, d_right, contacts, contact_d, columns,
                                 n_regions, ids.shape[0], params)
    # each run stands where its nearer end does: the ground it meets in its own columns agrees
    # with that end (a run between the edges of two nearer objects meets the ground behind them)
    stands = slanted | _agree(np.maximum(d_left, d_right), met.mean(region, x0, x1), params.contact_tolerance_px,
                              params.contact_tolerance_fraction)
    chosen = bracketed & standing[region] & stands
    if not chosen.any():
        return None
    return BracketedRuns(y[chosen], x0[chosen], x1[chosen], xl[chosen], xr[chosen], d_left[chosen], d_right[chosen],
                         contact_left[chosen], contact_right[chosen], stepped[chosen])


def _end_contacts(met: _GroundMet, region: np.ndarray, x0: np.ndarray, x1: np.ndarray, candidates: np.ndarray,
                  params: TexturelessFillParameters) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The ground under each run's ends, and whether it steps.

    Returns ``float64 (n,)`` twice: the ground disparity where each run's region meets the ground
    in the run's first and in its last :data:`END_CONTACT_COLUMNS` columns (their means), for the
    ``candidates`` (``bool (n,)``) among the runs (region ``region[i]``, columns ``x0[i]..x1[i]``)
    that meet the ground in ``min_contact_fraction`` of their columns, along the straight line in
    disparity between those two (placed at the centres of their columns) within
    ``slant_tolerance_px`` in :data:`STRAIGHT_SHARE` of them, NaN for the others; and ``bool
    (n,)``: the runs with contacts whose ground a step fits better than a line (:func:`_steps`). The
    bottom of a plane standing on the ground is a straight line in the image, its disparity linear
    along it; two objects at two depths meet the ground with a step."""
    left_end, right_end = np.minimum(x0 + END_CONTACT_COLUMNS - 1, x1), np.maximum(x1 - END_CONTACT_COLUMNS + 1, x0)
    left, right = met.mean(region, x0, left_end), met.mean(region, right_end, x1)
    tested = np.flatnonzero(candidates & np.isfinite(left) & np.isfinite(right))
    run, xs = _run_columns(x0[tested], x1[tested])
    at_left, at_right = (x0[tested] + left_end[tested]) / 2, (right_end[tested] + x1[tested]) / 2  # windows' centres
    slope = (right[tested] - left[tested]) / np.maximum(at_right - at_left, 1.0)
    line = left[tested][run] + slope[run] * (xs - at_left[run])
    ground_d = met.at[region[tested][run], xs]
    measured = np.isfinite(ground_d)
    near_line = measured & (np.abs(ground_d - line) <= params.slant_tolerance_px)
    n_measured = np.bincount(run, weights=measured, minlength=tested.size)
    straight = ((n_measured >= params.min_contact_fraction * (x1[tested] - x0[tested] + 1))
                & (np.bincount(run, weights=near_line, minlength=tested.size) >= STRAIGHT_SHARE * n_measured))
    kept, stepped = np.zeros(x0.size, bool), np.zeros(x0.size, bool)
    kept[tested[straight]] = True
    on_straight = measured & straight[run]              # the step matters only where there are contacts
    renumbered = np.cumsum(straight) - 1
    stepped[tested[straight]] = _steps(renumbered[run[on_straight]], xs[on_straight], ground_d[on_straight],
                                       int(straight.sum()))
    return np.where(kept, left, np.nan), np.where(kept, right, np.nan), stepped


def _steps(run: np.ndarray, xs: np.ndarray, ground_d: np.ndarray, n_runs: int) -> np.ndarray:
    """``bool (n_runs,)``: which runs' ground a step fits better than a straight line does: two
    levels, split between two of the run's columns, leave less squared error than the
    least-squares line. Two objects side by side a little apart in depth meet the ground with a
    step smaller than twice ``slant_tolerance_px``, which the line's tolerance alone does not see.
    ``ground_d`` (finite) at columns ``xs`` of runs ``run`` (``(m,)`` each, run by run, left to
    right)."""
    xs, ground_d = xs.astype(np.float64), ground_d.astype(np.float64)

    def per_run(values: np.ndarray) -> np.ndarray:
        return np.bincount(run, weights=values, minlength=n_runs)

    n, sum_x, sum_d, sum_dd = per_run(np.ones_like(xs)), per_run(xs), per_run(ground_d), per_run(ground_d ** 2)
    with np.errstate(invalid="ignore", divide="ignore"):
        spread_x = per_run(xs ** 2) - sum_x ** 2 / n
        covariance = per_run(xs * ground_d) - sum_x * sum_d / n
        line_error = sum_dd - sum_d ** 2 / n - np.where(spread_x > 0, covariance ** 2 / spread_x, 0.0)
        # each split after a column that is not its run's last: the left part up to it, the right the rest
        start = np.searchsorted(run, run)
        cumulative_d, cumulative_dd = np.cumsum(ground_d), np.cumsum(ground_d ** 2)
        left_d = cumulative_d - np.where(start > 0, cumulative_d[start - 1], 0.0)
        left_dd = cumulative_dd - np.where(start > 0, cumulative_dd[start - 1], 0.0)
        left_n = np.arange(run.size) - start + 1.0
        right_n = n[run] - left_n
        split = right_n > 0
        step_error = (left_dd - left_d ** 2 / left_n + (sum_dd[run] - left_dd)
                      - (sum_d[run] - left_d) ** 2 / right_n)
    best_step = np.full(n_runs, np.inf)
    np.minimum.at(best_step, run[split], step_error[split])
    return best_step < line_error - ROUNDING_PX2 * n


ROUNDING_PX2 = 1e-6
"""Squared error per column (pixels^2) below which a step and a line fit the ground equally well
(the rounding of the sums; the ground's rows are 0.1 px of disparity apart in the synthetic rig)."""


def _run_columns(x0: np.ndarray, x1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every pixel of the runs ``x0[i]..x1[i]`` (``int (n,)``, inclusive): the run it lies in and
    its column, ``int64 (m,)`` each, run by run from left to right."""
    lengths = x1 - x0 + 1
    run = np.repeat(np.arange(lengths.size), lengths)
    return run, x0[run] + np.arange(lengths.sum()) - np.repeat(np.cumsum(lengths) - lengths, lengths)


def _checked_maps(candidates: np.ndarray, id_map: np.ndarray, disparity: np.ndarray,
                  labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``id_map`` as contiguous ``int32`` and ``disparity`` as contiguous ``float32``, or
    :class:`InvalidInputError` for ids beyond 32 bits or maps of different shapes."""
    id_map = np.asarray(id_map)
    if id_map.size and not (np.iinfo(np.int32).min <= id_map.min() and id_map.max() <= np.iinfo(np.int32).max):
        raise InvalidInputError(f"id_map: obstacle ids must fit in 32 bits, got {id_map.min()}..{id_map.max()}")
    ids = np.ascontiguousarray(id_map, dtype=np.int32)
    d = np.ascontiguousarray(disparity, dtype=np.float32)
    if d.shape != ids.shape or np.shape(labels) != ids.shape or np.shape(candidates) != ids.shape:
        raise InvalidInputError(f"candidates {np.shape(candidates)}, id_map {ids.shape}, disparity {d.shape} and "
                                f"labels {np.shape(labels)} must have one shape")
    return ids, d


def fill_textureless(candidates: np.ndarray, id_map: np.ndarray, disparity: np.ndarray, labels: np.ndarray,
                     ground: GroundPlane, params: TexturelessFillParameters = TexturelessFillParameters()
                     ) -> tuple[np.ndarray, np.ndarray]:
    """The id map and disparity with the textureless regions filled (module docstring).

    Parameters
    ----------
    candidates
        ``int32 (H, W)``: :func:`textureless_candidates` of the pair; a region is the pixels of
        one candidate set that have no disparity and belong to no obstacle (at least
        ``min_area_px`` of them).
    id_map
        ``int (H, W)``: the obstacle each pixel belongs to, 0 for none.
    disparity
        ``float32 (H, W)`` disparity in pixels, NaN where unmatched.
    labels
        ``uint8 (H, W)`` phase-1 labels (:class:`~stereo_obstacles.labels.Label`).
    ground
        The ground plane in disparity space.
    params
        When to fill.

    Returns
    -------
    tuple of numpy.ndarray
        ``int32 (H, W)`` ids and ``float32 (H, W)`` disparities: copies of the inputs with the
        filled pixels set (the inputs themselves when nothing is filled).
    """
    return paint_runs(id_map, disparity, bracketed_runs(candidates, id_map, disparity, labels, ground, params))


def _standing_regions(region_rows: np.ndarray, bracketed: np.ndarray, d_left: np.ndarray, d_right: np.ndarray,
                      contacts: np.ndarray, contact_d: np.ndarray, columns: np.ndarray, n_regions: int, height: int,
                      params: TexturelessFillParameters) -> np.ndarray:
    """``bool (n_regions + 1,)``: the regions with enough bracketed rows that stand on the ground
    at their outlines' depth (module docstring). ``region_rows`` numbers each run's region and
    row as ``region * height + row``."""
    rows = np.bincount(np.unique(region_rows) // height, minlength=n_regions + 1)
    rows_bracketed = np.bincount(np.unique(region_rows[bracketed]) // height, minlength=n_regions + 1)
    region = region_rows // height
    standing = np.zeros(n_regions + 1, bool)
    for k in np.flatnonzero(rows_bracketed >= np.maximum(params.min_bracketed_fraction * rows, 1)):
        meets = contacts[:, 0] == k
        if np.count_nonzero(meets) < params.min_contact_fraction * columns[k]:
            continue
        ends = np.concatenate([d_left[bracketed & (region == k)], d_right[bracketed & (region == k)]])
        standing[k] = bool(_agree(float(np.median(ends)), float(np.median(contact_d[meets])),
                                  params.contact_tolerance_px, params.contact_tolerance_fraction))
    return standing


def paint_runs(id_map: np.ndarray, disparity: np.ndarray,
               runs: BracketedRuns | None) -> tuple[np.ndarray, np.ndarray]:
    """``int32`` copies of ``id_map`` and ``float32`` of ``disparity`` (``(H, W)``) with each run
    (:func:`bracketed_runs` of them) given the disparities interpolated between its ends and the
    id of its nearer end; the maps themselves (as those types) when ``runs`` is ``None``."""
    ids, d = np.asarray(id_map, dtype=np.int32), np.asarray(disparity, dtype=np.float32)
    if runs is None:
        return ids, d
    run, xs = _run_columns(runs.x0, runs.x1)
    ys = runs.y[run]
    left_d, right_d = runs.d_left[run], runs.d_right[run]
    t = (xs - runs.xl[run]) / (runs.xr[run] - runs.xl[run])
    nearer = np.where(left_d >= right_d, runs.xl[run], runs.xr[run])
    ids, d = ids.copy(), d.copy()
    d[ys, xs] = left_d + (right_d - left_d) * t
    ids[ys, xs] = ids[ys, nearer]
    return ids, d


MIN_OWNER_SHARE = 0.25
"""An obstacle widens to the filled pixels of a connected patch only when it holds at least this
share of them: an outline piece of an object whose face another piece fills holds a sliver."""


def _widening_pixels(owners: np.ndarray, ys: np.ndarray, xs: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """``bool (n,)``: which filled pixels (``(ys, xs)``, obstacle ``owners``) widen their
    obstacle: those of an obstacle holding at least :data:`MIN_OWNER_SHARE` of the filled pixels
    of their 8-connected patch (an object found as two outline pieces is widened once; two
    objects sharing a patch each keep their part)."""
    mask = np.zeros(shape, np.uint8)
    mask[ys, xs] = 1
    _, patches = cv2.connectedComponents(mask, connectivity=8, ltype=cv2.CV_32S)
    pairs, pair_of, counts = np.unique(np.stack([patches[ys, xs].astype(np.int64), owners.astype(np.int64)]),
                                       axis=1, return_inverse=True, return_counts=True)
    _, patch_of_pair = np.unique(pairs[0], return_inverse=True)
    share = counts / np.bincount(patch_of_pair, weights=counts)[patch_of_pair]
    return (share >= MIN_OWNER_SHARE)[np.ravel(pair_of)]


def widen_obstacles(obstacle_list: ObstacleList, filled_ids: np.ndarray, filled_disparity: np.ndarray,
                    calibration: StereoCalibration, corridor_width_m: float) -> ObstacleList:
    """``obstacle_list`` with each obstacle that :func:`fill_textureless` gave pixels widened to
    them: its box takes them in, and its lateral extent (and so its width) reaches the 1st-99th
    percentiles of their ``x`` (metres, at the filled disparities; pixels of no finite, positive
    depth left out) where those lie beyond it; the corridor summary follows
    (``corridor_width_m`` wide). Only the pixels of an obstacle holding at least
    :data:`MIN_OWNER_SHARE` of a connected patch of filled pixels count. Obstacles without a lateral extent (measured without a
    calibration) and ids the list does not hold are left alone.

    ``filled_ids`` ``int (H, W)`` and ``filled_disparity`` ``float32 (H, W)`` are the filled maps;
    a pixel is filled where ``filled_ids`` differs from ``obstacle_list.id_map``.

    Raises
    ------
    InvalidInputError
        No calibration, or maps of another shape than the id map.
    """
    if not isinstance(calibration, StereoCalibration):
        raise InvalidInputError(f"calibration must be a StereoCalibration, got {type(calibration).__name__}")
    shape = np.shape(obstacle_list.id_map)
    if np.shape(filled_ids) != shape or np.shape(filled_disparity) != shape:
        raise InvalidInputError(f"filled_ids {np.shape(filled_ids)} and filled_disparity {np.shape(filled_disparity)} "
                                f"must have the id map's shape {shape}")
    ys, xs = np.nonzero(np.asarray(filled_ids) != obstacle_list.id_map)
    shifted = np.asarray(filled_disparity)[ys, xs].astype(np.float64) + calibration.doffs_px
    depth = np.isfinite(shifted) & (shifted > 0)
    ys, xs, shifted = ys[depth], xs[depth], shifted[depth]
    if ys.size == 0:
        return obstacle_list
    owners = np.asarray(filled_ids)[ys, xs]
    widening = _widening_pixels(owners, ys, xs, shape)
    ys, xs, shifted, owners = ys[widening], xs[widening], shifted[widening], owners[widening]
    lateral = (xs - calibration.cx_px) * (calibration.focal_baseline_px_m / shifted) / calibration.focal_px
    widened = []
    for o in obstacle_list.obstacles:
        mine = owners == o.id
        if not mine.any() or o.lateral_extent_m is None:
            widened.append(o)
            continue
        x_lo, x_hi = np.percentile(lateral[mine], EXTENT_PERCENTILES)
        left = min(o.lateral_extent_m[0], round(float(x_lo), 3))
        right = max(o.lateral_extent_m[1], round(float(x_hi), 3))
        box = (min(o.box_px[0], int(xs[mine].min())), min(o.box_px[1], int(ys[mine].min())),
               max(o.box_px[2], int(xs[mine].max()) + 1), max(o.box_px[3], int(ys[mine].max()) + 1))
        wider = (left, right) != o.lateral_extent_m
        widened.append(replace(o, box_px=box, lateral_extent_m=(left, right),
                               width_m=round(right - left, 3) if wider else o.width_m))
    return replace(obstacle_list, obstacles=tuple(widened),
                   corridor=corridor_summary(tuple(widened), corridor_width_m))

__all__ = ["BracketedRuns", "TexturelessFillParameters", "bracketed_runs", "fill_textureless", "paint_runs",
           "textureless_candidates", "widen_obstacles"]
