"""Obstacles cut by the strip at the left image border that only the left camera sees.

A left pixel ``x`` with disparity ``d`` is seen by the right camera at ``x - d``: for ``x < d``
that lies outside the right image, so no disparity can be matched there. A wall running past
the left border therefore loses its nearest part, up to ``d`` columns of it (the nearer, the
wider). Phase 1 still labels those pixels obstacle (it needs one image only), so an obstacle
group whose matched pixels reach the strip's edge is continued into the strip: a plane
``d = a x + b y + c`` is fitted (least squares) to the group's pixels in the
``fit_width_px`` columns next to the strip, and each obstacle-labelled, unmatched pixel to
their left, in a run reaching the group's first column in its row, gets the plane's disparity
as long as the plane puts it in the strip (``d > x``, or within ``reach_px`` of it). Only the
obstacle measurement uses those extrapolated disparities; the delivered disparity and depth
maps stay measured values.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import plain_numbers
from stereo_obstacles.plane_fit import least_squares_plane

__all__ = ["BlindStripParameters", "extend_into_blind_strip"]


@dataclass(frozen=True)
class BlindStripParameters:
    """When and how a group is continued into the left camera's own strip.

    Attributes
    ----------
    fit_width_px : int
        Columns of the group, from its first one, that the plane is fitted to.
    min_fit_pixels : int
        Pixels the fit needs.
    reach_px : float
        The group must start within this many pixels of the strip's edge (its first column at
        most its disparity there plus ``reach_px``), and the unmatched pixels it is continued
        over may lie this far outside the strip (a 5 x 5 window next to the edge often goes
        unmatched too).
    """

    fit_width_px: int = 24
    min_fit_pixels: int = 60
    reach_px: float = 3.0

    def __post_init__(self) -> None:
        plain_numbers(self)                      # NumPy scalars as Python numbers (JSON-ready)
        if self.fit_width_px < 2 or self.min_fit_pixels < 3 or not self.reach_px >= 0:
            raise InvalidInputError("fit_width_px must be >= 2, min_fit_pixels >= 3 and reach_px >= 0")


def extend_into_blind_strip(groups: np.ndarray, disparity: np.ndarray, obstacle_mask: np.ndarray,
                            params: BlindStripParameters = BlindStripParameters()
                            ) -> tuple[np.ndarray, np.ndarray, int]:
    """Continue the groups that reach the strip's edge into the strip.

    Parameters
    ----------
    groups : ndarray of int, shape (H, W)
        Obstacle groups, 0 for none (:func:`stereo_obstacles.obstacle_grouping.group_obstacle_pixels`).
    disparity : ndarray of float32, shape (H, W)
        Measured disparity in pixels, NaN where unmatched.
    obstacle_mask : ndarray of bool, shape (H, W)
        Pixels phase 1 calls obstacle.

    Returns
    -------
    groups, disparity : ndarray, shape (H, W)
        Copies with the extrapolated pixels added (the inputs themselves when none is).
    n_extended : int
        Pixels added.
    """
    if not groups.shape == disparity.shape == obstacle_mask.shape or groups.ndim != 2:
        raise InvalidInputError(f"groups {groups.shape}, disparity {disparity.shape} and obstacle_mask "
                                f"{obstacle_mask.shape} must be one 2-D shape")
    out_groups, out_disparity, n_extended = groups, disparity, 0
    h, w = groups.shape
    finite = disparity[np.isfinite(disparity)]
    if finite.size == 0:
        return out_groups, out_disparity, n_extended
    # everything happens in the columns a strip can cover, plus the fit's
    band = int(min(w, max(0.0, float(finite.max())) + params.reach_px + params.fit_width_px + 1))
    band_groups = groups[:, :band]
    for group in np.unique(band_groups[band_groups > 0]):
        ys, xs = np.nonzero(band_groups == group)
        ds = disparity[ys, xs].astype(np.float64)
        first = int(xs.min())
        near = xs < first + params.fit_width_px
        if near.sum() < params.min_fit_pixels or first > float(ds[near].max()) + params.reach_px:
            continue
        plane = least_squares_plane(xs[near], ys[near], ds[near])
        if plane is None:
            continue
        # each row of the group walks left from just before its first pixel in that row
        row_first = np.full(h, w)
        np.minimum.at(row_first, ys, xs)
        active = np.zeros(h, bool)
        # a row whose first pixel lies far right of the strip's edge cannot reach into the strip
        for x in range(min(int(row_first[ys].max()) - 1, first + params.fit_width_px), -1, -1):
            active |= row_first == x + 1
            cand = np.flatnonzero(active)
            if cand.size == 0:
                continue
            predicted = plane[0] * x + plane[1] * cand + plane[2]
            ok = (obstacle_mask[cand, x] & np.isnan(disparity[cand, x]) & (predicted > x - params.reach_px)
                  & (groups[cand, x] == 0))
            active[cand[~ok]] = False
            if ok.any():
                if out_groups is groups:
                    out_groups, out_disparity = groups.copy(), disparity.copy()
                out_groups[cand[ok], x] = group
                out_disparity[cand[ok], x] = predicted[ok]
                n_extended += int(ok.sum())
    return out_groups, out_disparity, n_extended
