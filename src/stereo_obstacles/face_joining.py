"""Joining obstacles that are the two outlines of one textureless face.

A face of dull paint or plastic gives the matcher nothing inside its outline
(:mod:`stereo_obstacles.textureless_fill`), so a near box or cylinder can come out as two or three
obstacles: its left edge, its right edge, a lit strip. Each is measured on its own pixels, and the
one that overlaps the object most need not be the nearest (a cylinder 2.79 m away listed at 2.84,
2.88 and 2.96 m). The textureless fill finds the rows of such a face that are bracketed on both
sides by obstacle pixels of agreeing disparity and that stand on the ground at that depth, or
whose two ends each stand on the ground at their own depth (a face slanted in depth); when
the two ends of at least ``min_runs`` of them belong to two different obstacles, both are one
surface, and the obstacles are joined, if

* the two ends of each of those runs lie within ``end_tolerance_m`` of each other in depth, and
* the two obstacles' median depths lie within ``max_depth_gap_m`` of each other, or their depths
  at the ``near_percentile``-th percentile of their disparities do: their nearer parts. An
  outline piece holds the background its fattened fringe covers, or a face receding from the
  outline, and either pulls its median back (the two outlines of a textureless box 6.29 m away:
  medians 0.61 m apart, 90th percentiles 0.29 m; ``docs/pipeline.md``, "Outline pieces read at
  their nearer part", session 45);

or when at least ``min_runs`` of them stand on the ground at both ends: each end within
``end_tolerance_m`` in depth of the ground the face meets under the run's first (or last)
columns, the ground it meets along the run on the straight line between those two
(``contact_left`` and ``contact_right`` of
:class:`~stereo_obstacles.textureless_fill.BracketedRuns`, which the fill gives only then), and,
unless the two ends lie within ``end_tolerance_m`` of each other, no step fitting that ground
better than the line (``stepped``: two objects of one colour side by side, a little apart in
depth). Such a face may be slanted in depth, its outlines at two depths; its obstacles' medians
may lie farther apart too, one of them holding background beside the outline.

Joins chain: three pieces of a long face, each pair within the tolerances, make one obstacle
that may span more in depth (the pieces of a wall receding from the camera are one wall); the
joined obstacle is measured by :func:`stereo_obstacles.obstacle_joining.measure_joined`.

The tolerances are in metres, not pixels of disparity, because a fixed disparity tolerance is
many metres at 10 m: with the fill's own (1 px or 10 %), a box at 7.3 m was joined to the wall
1.9 m behind it (``docs/pipeline.md``, "Obstacles that bracket one textureless face").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.field_checks import check_integers, check_numbers
from stereo_obstacles.textureless_fill import BracketedRuns

__all__ = ["FaceJoiningParameters", "obstacles_sharing_a_face"]


@dataclass(frozen=True)
class FaceJoiningParameters:
    """When two obstacles bracketing one textureless face are joined (module docstring)."""

    min_runs: int = 5
    end_tolerance_m: float = 0.15
    max_depth_gap_m: float = 0.3
    near_percentile: float = 90.0
    """Percentile (0-100) of each obstacle's disparities compared when their medians lie farther
    apart than ``max_depth_gap_m``: a high one reads the obstacle's nearer part."""

    def __post_init__(self) -> None:
        check_integers(self, (("min_runs", 1, 10 ** 6),))
        check_numbers(self, (("end_tolerance_m", 0.0, math.inf), ("max_depth_gap_m", 0.0, math.inf),
                             ("near_percentile", 0.0, 100.0)))


def _within_m(d_a: np.ndarray | float, d_b: np.ndarray | float, metres: float,
              calibration: StereoCalibration) -> np.ndarray:
    """Whether disparities ``d_a`` and ``d_b`` (pixels) lie within ``metres`` of each other in
    depth, ``Z = f B / (d + doffs)``; not where either has no positive ``d + doffs``."""
    shifted_a = np.asarray(d_a, dtype=np.float64) + calibration.doffs_px
    shifted_b = np.asarray(d_b, dtype=np.float64) + calibration.doffs_px
    with np.errstate(divide="ignore", invalid="ignore"):
        gap = calibration.focal_baseline_px_m * np.abs(1.0 / shifted_a - 1.0 / shifted_b)
    return (shifted_a > 0) & (shifted_b > 0) & (gap <= metres)


def _own_depths_agree(first: np.ndarray, second: np.ndarray, params: FaceJoiningParameters,
                      calibration: StereoCalibration) -> bool:
    """Whether two obstacles' disparities (``float32 (n,)`` each, pixels, NaN where unmatched) lie
    within ``max_depth_gap_m`` of each other in depth at their medians or at their
    ``near_percentile``-th percentiles."""
    return any(bool(_within_m(np.nanpercentile(first, q), np.nanpercentile(second, q), params.max_depth_gap_m,
                              calibration)) for q in (50.0, params.near_percentile))


def obstacles_sharing_a_face(runs: BracketedRuns | None, id_map: np.ndarray, disparity: np.ndarray,
                             calibration: StereoCalibration,
                             params: FaceJoiningParameters = FaceJoiningParameters()) -> list[tuple[int, int]]:
    """The pairs ``(a, b)``, ``a < b``, of obstacle ids to join (module docstring).

    Parameters
    ----------
    runs
        :func:`stereo_obstacles.textureless_fill.bracketed_runs` of ``id_map``; ``None``: no runs.
    id_map
        ``int (H, W)``: the obstacle each pixel belongs to, 0 for none.
    disparity
        ``float32 (H, W)`` disparity in pixels, NaN where unmatched.
    calibration
        The rig, for the tolerances in metres.
    params
        When to join.
    """
    if runs is None:
        return []
    ids = np.asarray(id_map)
    a, b = ids[runs.y, runs.xl], ids[runs.y, runs.xr]
    level = _within_m(runs.d_left, runs.d_right, params.end_tolerance_m, calibration)
    # both ends on the ground at their own depths: one face, unless the ground steps between ends
    # at two depths (two objects of one colour side by side)
    standing_ends = ((level | ~runs.stepped)
                     & _within_m(runs.d_left, runs.contact_left, params.end_tolerance_m, calibration)
                     & _within_m(runs.d_right, runs.contact_right, params.end_tolerance_m, calibration))
    counted = (a != b) & (a > 0) & (b > 0) & (level | standing_ends)
    if not counted.any():
        return []
    pair_keys = np.stack([np.minimum(a, b)[counted], np.maximum(a, b)[counted]])
    pairs, pair_of, counts = np.unique(pair_keys, axis=1, return_inverse=True, return_counts=True)
    standing_counts = np.bincount(np.ravel(pair_of), weights=standing_ends[counted], minlength=counts.size)
    joined = []
    for (first, second), count, standing_count in zip(pairs.T, counts, standing_counts):
        if count < params.min_runs:
            continue
        if standing_count >= params.min_runs:      # a face standing on the ground from one end to the other
            joined.append((int(first), int(second)))
            continue
        if _own_depths_agree(disparity[ids == first], disparity[ids == second], params, calibration):
            joined.append((int(first), int(second)))
    return joined
