"""Obstacles cut by the strip at the left image border that only the left camera sees.

A left pixel ``x`` with disparity ``d`` is seen by the right camera at ``x - d``: for ``x < d``
that lies outside the right image, so no disparity can be matched there. A wall running past
the left border therefore loses its nearest part, up to ``d`` columns of it (the nearer, the
wider). Phase 1 still labels those pixels (it needs one image only), so an obstacle group
whose matched pixels reach the strip's edge is continued into the strip: a plane
``d = a x + b y + c`` is fitted (least squares) to the group's pixels in the
``fit_width_px`` columns next to the strip, and each unmatched pixel to their left, in a run
reaching the group's first column in its row, gets the plane's disparity as long as the plane
puts it in the strip (``d > x``, or within ``reach_px`` of it) and the pixel looks like the
group: phase 1 calls it obstacle, or (given the chroma) phase 1 gives it the label most of the
fitted pixels have and its chroma lies within ``max_chroma_distance`` of their median chroma.
The second holds an object coloured like the ground, which phase 1 calls ground or shadow and
only the disparities make an obstacle: a grey concrete wall at 1.6-3.2 m, called shadow, whose
first matched column was 36 was measured there, at 1.79 m instead of 1.58 m (``docs/pipeline.md``,
session 38). Asking for the group's own label as well keeps the lit ground beyond a
shadow-coloured wall that ends inside the strip out of it; ground of the wall's label and colour
beyond its end would still be taken. Only the obstacle measurement uses those extrapolated
disparities; the delivered disparity and depth maps stay measured values.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stereo_obstacles.colour_split import ColourSplitParameters, chroma_apart
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import plain_numbers
from stereo_obstacles.labels import Label
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
    max_chroma_distance : float
        A pixel phase 1 does not call obstacle continues the group when it has the fitted
        pixels' most common label and its chroma lies less than this from their median chroma, in
        ``(a*, b*)``: the colour split's ``min_chroma_distance``, below which two colours are one.
    """

    fit_width_px: int = 24
    min_fit_pixels: int = 60
    reach_px: float = 3.0
    max_chroma_distance: float = ColourSplitParameters.min_chroma_distance

    def __post_init__(self) -> None:
        plain_numbers(self)                      # NumPy scalars as Python numbers (JSON-ready)
        if (self.fit_width_px < 2 or self.min_fit_pixels < 3 or not self.reach_px >= 0
                or not self.max_chroma_distance >= 0):
            raise InvalidInputError("fit_width_px must be >= 2, min_fit_pixels >= 3, reach_px >= 0 and "
                                    "max_chroma_distance >= 0")


def extend_into_blind_strip(groups: np.ndarray, disparity: np.ndarray, labels: np.ndarray,
                            params: BlindStripParameters = BlindStripParameters(), *,
                            chroma: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, int]:
    """Continue the groups that reach the strip's edge into the strip.

    Parameters
    ----------
    groups : ndarray of int, shape (H, W)
        Obstacle groups, 0 for none (:func:`stereo_obstacles.obstacle_grouping.group_obstacle_pixels`).
    disparity : ndarray of float32, shape (H, W)
        Measured disparity in pixels, NaN where unmatched.
    labels : ndarray of uint8, shape (H, W)
        Phase-1 labels (:class:`stereo_obstacles.labels.Label` values).
    params
        Which groups, and how far into the strip.
    chroma : ndarray of uint8, shape (H, W, 2), optional
        Chroma of the left image (:attr:`stereo_obstacles.colour_split.ColourCue.chroma`); without
        it only pixels phase 1 calls obstacle continue a group.

    Returns
    -------
    groups, disparity : ndarray, shape (H, W)
        Copies with the extrapolated pixels added (the inputs themselves when none is).
    n_extended : int
        Pixels added.
    """
    labels = np.asarray(labels)
    if not groups.shape == disparity.shape == labels.shape or groups.ndim != 2:
        raise InvalidInputError(f"groups {groups.shape}, disparity {disparity.shape} and labels "
                                f"{labels.shape} must be one 2-D shape")
    if labels.dtype != np.uint8:
        raise InvalidInputError(f"labels must be uint8 phase-1 labels, got {labels.dtype}")
    if chroma is not None and (chroma.shape != groups.shape + (2,) or chroma.dtype != np.uint8):
        raise InvalidInputError(f"chroma ({chroma.dtype} {chroma.shape}) must be uint8 (H, W, 2) for the groups' "
                                f"(H, W) = {groups.shape}")
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
        if chroma is not None:      # the fitted pixels' colour and most common label
            colour = np.median(chroma[ys[near], xs[near]], axis=0)
            own_label = np.bincount(labels[ys[near], xs[near]]).argmax()
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
            looks_alike = labels[cand, x] == Label.OBSTACLE.value
            if chroma is not None:
                looks_alike |= (labels[cand, x] == own_label) & ~chroma_apart(
                    chroma[cand, x].astype(np.int32), colour, params.max_chroma_distance)
            ok = looks_alike & np.isnan(disparity[cand, x]) & (predicted > x - params.reach_px) & (groups[cand, x] == 0)
            active[cand[~ok]] = False
            if ok.any():
                if out_groups is groups:
                    out_groups, out_disparity = groups.copy(), disparity.copy()
                out_groups[cand[ok], x] = group
                out_disparity[cand[ok], x] = predicted[ok]
                n_extended += int(ok.sum())
    return out_groups, out_disparity, n_extended
