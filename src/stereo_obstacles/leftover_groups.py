"""A farther object's strip beside a nearer one, standing pixels that no group took.

The grouping (:mod:`stereo_obstacles.obstacle_grouping`) gives each 8 x 8 cell the median
disparity of its pixels, and a pixel joins its cell's group only when its own disparity agrees.
A farther object that shows only as a strip a few pixels wide beside a nearer one (a cylinder
behind a pole, seen 6 px wide on one side of it) falls in cells that the nearer object's pixels
hold: its matches are right, they stand above the ground, and no group takes them (scene 315's
cylinder at 9.89 m, missed: ``docs/pipeline.md``, session 41).

Here the standing pixels that phase 1 calls obstacle and that no group took are linked across
``link_px`` (a strip broken by a few unmatched pixels is one piece), and each piece is cut into
windows of disparities (``2 max(window_px, window_rel * d)`` wide), densest first, while an
object's count of its pixels remains: the strip, and the nearer object's stray pixels beside it,
each in a window of its own (scene 588's box, an L 2-5 px wide around a nearer box, holds fewer
pixels than the strays its piece takes in). A window becomes a group of its own when

- it holds an object's pixel count by the grouping's rule (far ones fewer:
  :func:`stereo_obstacles.obstacle_grouping.object_sized`);
- it lies behind every group within ``ring_px`` of it, by more than ``max(behind_px, behind_rel *
  d)``, and there is at least one: a strip beside a nearer object, the one place cells lose it (a
  piece at a neighbour's depth is that neighbour's halo, the matching's spread of it over the
  background);
- its lowest pixel, at its median disparity, lies within ``max_foot_m`` of the ground (above
  or below): it stands on the ground. Strips of sky beside a pole, matched between the pole and
  the sky, float 0.7 m or more above theirs (1287, 1336: false alarms without this test).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import check_integers, check_numbers
from stereo_obstacles.ground_plane import GroundPlane, height_above_ground_m
from stereo_obstacles.labels import Label
from stereo_obstacles.obstacle_grouping import GroupingParameters, object_sized

__all__ = ["LeftoverParameters", "leftover_groups"]


@dataclass(frozen=True)
class LeftoverParameters:
    """Which standing pixels that no group took become a group (module docstring).

    Attributes
    ----------
    link_px : int
        Leftover pixels this far apart (pixels) are one piece.
    window_px, window_rel : float
        A piece is cut into disparity windows ``2 max(window_px, window_rel * d)`` wide (pixels;
        ``d`` the median disparity of the pixels not yet in a window), densest first.
    ring_px : int
        Groups within this (pixels) of the piece are its neighbours.
    behind_px, behind_rel : float
        Each neighbour's median disparity lies more than ``max(behind_px, behind_rel * d)`` above
        the piece's (pixels).
    max_foot_m : float
        Most height (metres) of the piece's lowest pixel above the ground, or depth below it, at
        the piece's median disparity.
    """

    link_px: int = 2
    window_px: float = 0.5
    window_rel: float = 0.05
    ring_px: int = 3
    behind_px: float = 1.0
    behind_rel: float = 0.1
    max_foot_m: float = 0.3

    def __post_init__(self) -> None:
        check_integers(self, (("link_px", 0, 100), ("ring_px", 1, 100)))
        check_numbers(self, (("window_px", 0.0, 100.0), ("window_rel", 0.0, 1.0), ("behind_px", 0.0, 1000.0),
                             ("behind_rel", 0.0, 1.0), ("max_foot_m", 0.0, 100.0)))


def leftover_groups(groups: np.ndarray, disparity: np.ndarray, standing: np.ndarray, labels: np.ndarray,
                    ground: GroundPlane, calibration: StereoCalibration,
                    grouping: GroupingParameters = GroupingParameters(),
                    params: LeftoverParameters = LeftoverParameters()) -> np.ndarray:
    """``groups`` with the windows of leftover pieces that pass (module docstring) as new groups.

    Parameters
    ----------
    groups
        ``int (H, W)`` group of each pixel, ``1..N``, 0 for none.
    disparity
        ``float32 (H, W)`` disparity in pixels, NaN where unmatched.
    standing
        ``bool (H, W)``: the pixels that stand above the ground.
    labels
        ``uint8 (H, W)`` phase-1 labels.
    ground
        The ground plane in disparity.
    calibration
        The rig, for the height of a piece's lowest pixel in metres.
    grouping
        The grouping's parameters: an object's pixel count.
    params
        Which pieces.

    Returns
    -------
    numpy.ndarray
        ``int32 (H, W)``: ``groups`` with each new group numbered after the existing ones (a
        copy, unless ``groups`` is ``int32`` and nothing was added).

    Raises
    ------
    InvalidInputError
        Inputs of different heights and widths.
    """
    groups = np.asarray(groups)
    d = np.asarray(disparity, dtype=np.float32)
    if not (groups.ndim == 2 and d.shape == np.shape(standing) == np.shape(labels) == groups.shape):
        raise InvalidInputError(f"groups {groups.shape}, disparity {d.shape}, standing {np.shape(standing)} and "
                                f"labels {np.shape(labels)} must have one 2-D shape")
    if groups.size == 0:
        return groups.astype(np.int32, copy=False)
    leftover = (np.asarray(standing, dtype=bool) & (groups == 0) & (np.asarray(labels) == Label.OBSTACLE.value)
                & np.isfinite(d))
    least = grouping.far_min_fraction * grouping.min_object_pixels    # no object has fewer (far ones)
    size = 2 * params.link_px + 1
    _, piece_of, stats, _ = cv2.connectedComponentsWithStats(
        cv2.dilate(leftover.astype(np.uint8), np.ones((size, size), np.uint8)), connectivity=8)
    piece_of = np.where(leftover, piece_of, 0)
    counts = np.bincount(piece_of.ravel(), minlength=len(stats))
    result = groups.astype(np.int32, copy=False)
    number = int(groups.max(initial=0)) + 1
    neighbours = _Neighbours(groups, d, params)
    for piece in np.flatnonzero(counts[1:] >= least) + 1:
        x0, y0, width, height = (int(v) for v in stats[piece, [cv2.CC_STAT_LEFT, cv2.CC_STAT_TOP, cv2.CC_STAT_WIDTH,
                                                                cv2.CC_STAT_HEIGHT]])
        ys, xs = np.nonzero(piece_of[y0:y0 + height, x0:x0 + width] == piece)
        rest_ys, rest_xs = ys + y0, xs + x0           # the piece's pixels in no window yet
        while len(rest_ys) >= least:
            kept = _densest_window(d[rest_ys, rest_xs], params)
            ys, xs = rest_ys[kept], rest_xs[kept]
            rest_ys, rest_xs = rest_ys[~kept], rest_xs[~kept]
            median = float(np.median(d[ys, xs]))
            if (_object_sized(ys, xs, d, grouping)
                    and abs(_foot_m(ys, xs, median, ground, calibration)) <= params.max_foot_m
                    and neighbours.all_nearer(ys, xs, median)):
                if result is groups:
                    result = result.copy()              # the caller's groups stay as they were
                result[ys, xs] = number
                number += 1
    return result


def _densest_window(d: np.ndarray, params: LeftoverParameters) -> np.ndarray:
    """``bool (n,)``: the disparities ``d`` (``float (n,)``, pixels) in the window ``2 max(window_px,
    window_rel * median)`` wide that holds the most of them (the lowest such window)."""
    width = 2 * max(params.window_px, params.window_rel * float(np.median(d)))
    ordered = np.sort(d)
    inside = np.searchsorted(ordered, ordered + width, side="right") - np.arange(len(ordered))
    low = ordered[int(np.argmax(inside))]
    return (d >= low) & (d <= low + width)


def _object_sized(ys: np.ndarray, xs: np.ndarray, d: np.ndarray, grouping: GroupingParameters) -> bool:
    """Whether the pixels ``(ys, xs)`` hold an object's pixel count at their disparities ``d``
    (``float (H, W)``, pixels) by the grouping's rule (its test run on their box alone)."""
    y0, x0 = int(ys.min()), int(xs.min())
    box = np.full((int(ys.max()) - y0 + 1, int(xs.max()) - x0 + 1), -1, np.int64)
    box[ys - y0, xs - x0] = 0
    at = d[y0:y0 + box.shape[0], x0:x0 + box.shape[1]].astype(np.float64)     # read at the pixels only
    return bool(object_sized(box, at, np.array([len(ys)]), grouping)[0])


def _foot_m(ys: np.ndarray, xs: np.ndarray, median: float, ground: GroundPlane, calibration: StereoCalibration
            ) -> float:
    """Signed height (metres, :func:`~stereo_obstacles.ground_plane.height_above_ground_m`) of
    the pixels' lowest row, at their median column and their ``median`` disparity (pixels), above
    the ground; ``inf`` when that disparity puts the point at or beyond infinity."""
    if median + calibration.doffs_px <= 0.0:
        return math.inf
    z = calibration.focal_baseline_px_m / (median + calibration.doffs_px)
    column, row = float(np.median(xs)), float(ys.max())
    point = np.array([(column - calibration.cx_px) * z / calibration.focal_px,
                      (row - calibration.cy_px) * z / calibration.focal_px, z])
    return float(height_above_ground_m(ground, point, calibration))


class _Neighbours:
    """The groups beside a piece, and their median disparities (pixels), found once each."""

    def __init__(self, groups: np.ndarray, disparity: np.ndarray, params: LeftoverParameters) -> None:
        self._groups = groups
        self._disparity = disparity
        self._params = params
        self._medians: dict[int, float] = {}

    def all_nearer(self, ys: np.ndarray, xs: np.ndarray, median: float) -> bool:
        """Whether there are groups within ``ring_px`` of the pixels ``(ys, xs)`` and all of them lie
        more than ``max(behind_px, behind_rel * median)`` nearer than ``median`` (pixels)."""
        reach = self._params.ring_px
        h, w = self._groups.shape
        y0, x0 = max(int(ys.min()) - reach, 0), max(int(xs.min()) - reach, 0)
        y1, x1 = min(int(ys.max()) + reach + 1, h), min(int(xs.max()) + reach + 1, w)
        piece = np.zeros((y1 - y0, x1 - x0), np.uint8)
        piece[ys - y0, xs - x0] = 1
        ring = cv2.dilate(piece, np.ones((2 * reach + 1, 2 * reach + 1), np.uint8)) > 0
        beside = np.unique(self._groups[y0:y1, x0:x1][ring & (piece == 0)])
        beside = beside[beside > 0]
        step = max(self._params.behind_px, self._params.behind_rel * median)
        return len(beside) > 0 and all(self._median(int(g)) - median > step for g in beside)

    def _median(self, group: int) -> float:
        """The median disparity (pixels) of ``group``'s pixels, all matched."""
        if group not in self._medians:
            self._medians[group] = float(np.median(self._disparity[self._groups == group]))
        return self._medians[group]
