"""Grouping obstacle pixels with a disparity into separate objects.

Semi-dense disparity has holes, so pixels are grouped through a coarse grid of square cells:
a cell holding enough obstacle pixels with a disparity gets their median disparity, and two
4-adjacent cells belong to the same object when their disparities agree within a tolerance
(``max(abs_tolerance_px, rel_tolerance * d)``) and both cells are *pure* (most of their pixels
agree with their median): a cell straddling a depth edge has a median between the two
depths and would otherwise chain a near object to the far one behind it. A near pole in front of a far wall therefore
splits from the wall even where they touch in the image. Each pixel then joins its cell's
group only when its own disparity agrees with the cell's, which keeps stray background pixels
out of an object.

Two objects a little apart in depth (a pole 0.6 m in front of a box at 9 m: 0.56 px of
disparity) still link through cells of noisy pixels at the tolerance above. So the grouping
is done twice, the second time with the tighter ``split_tolerance_px``: a group that holds two
or more tight groups of an object's size whose median disparities are more than
``split_min_gap_px`` apart is split into them, its other pixels joining the one of nearest
median disparity. A tighter tolerance alone would break weakly matched objects into pieces
too small to report (measured in ``docs/pipeline.md``). A slanted surface comes out of the tight
grouping in bands too; tight groups that meet without a step in disparity stay together
(:mod:`stereo_obstacles.layer_steps`).

Objects closer in depth than that, touching in the image, are split where their colours
differ (:mod:`stereo_obstacles.colour_split`), when a colour cue of the left image is given; with
a calibration too, where two depths that the colours do not split stand apart on the ground.

Last, neighbouring groups that lie on one plane in disparity are joined
(:mod:`stereo_obstacles.coplanar_merging`): the pieces of a wall whose matches have gaps, or
whose disparity changes faster than the link tolerance from cell to cell; with a colour cue,
groups of one colour up to ``coplanar_colour_reach_cells`` cells apart too.

Groups with fewer pixels than an object's (``min_object_pixels``) take no part in the joining
and are dropped as noise; a far group needs fewer, as its image area shrinks with the square of
its distance (:class:`GroupingParameters`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import cv2
import numpy as np

from stereo_obstacles._obstacle_grouping_kernel import assign_pixels_kernel, cell_medians_kernel
from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.colour_split import ColourCue, ColourSplitParameters, split_groups_by_colour
from stereo_obstacles.coplanar_merging import merge_coplanar_groups
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import check_integers, check_numbers, check_positive, check_types
from stereo_obstacles.group_splits import GroupSplits
from stereo_obstacles.layer_steps import layer_surfaces


@dataclass(frozen=True)
class GroupingParameters:
    """How obstacle pixels are grouped.

    Attributes
    ----------
    cell_px : int
        Side of the square grid cells in pixels.
    min_cell_pixels : int
        Obstacle pixels with a disparity a cell needs to take part.
    abs_tolerance_px, rel_tolerance : float
        Two neighbouring cells (or a pixel and its cell) are consistent when their
        disparities differ by at most ``max(abs_tolerance_px, rel_tolerance * d)`` pixels.
    min_pure_fraction : float
        A cell links to its neighbours only when at least this fraction of its pixels agree
        with its median disparity.
    min_object_pixels : int
        Objects with fewer pixels are dropped as noise (but see the far ones below).
    far_min_fraction, far_disparity_px, far_min_width_px : float, float, int
        A far object shows fewer pixels: a group whose mean disparity ``d`` lies below
        ``far_disparity_px`` (pixels, > 0) needs only ``min_object_pixels * (d /
        far_disparity_px) ** 2`` of them (its image area shrinks with the square of its
        distance; ``d`` below 0 counts as 0), and no fewer than ``far_min_fraction *
        min_object_pixels`` (``far_min_fraction`` in [0, 1]), when it spans ``far_min_width_px``
        columns or more (at least 1; the fattened fringe beside an object is a few columns wide).
        This decides which groups are reported and joined; the depth-layer split and the colour
        split still split off only parts of ``min_object_pixels`` (docs/pipeline.md, session 29).
        ``far_min_fraction`` 1 switches it off.
    split_tolerance_px : float
        The tighter ``abs_tolerance_px`` of the second grouping that may split a group (see the
        module docstring); 0, or not below ``abs_tolerance_px``, switches the split off.
    split_min_gap_px : float
        The tight groups' median disparities must span more than this to split a group.
    split_min_step_px : float
        When the split runs: tight groups that touch with a median disparity difference of at
        most this many pixels between neighbouring pixels stay together, as the bands of one
        slanted surface (:mod:`stereo_obstacles.layer_steps`); 0 switches this off (each tight
        group a part).
    coplanar_tolerance_px, coplanar_rel_tolerance : float
        Neighbouring groups of an object's size are joined when, over each one's pixels, the
        plane of both differs from its own plane by at most ``coplanar_tolerance_px +
        coplanar_rel_tolerance * d`` pixels (root mean square;
        :mod:`stereo_obstacles.coplanar_merging`); ``coplanar_tolerance_px`` 0 switches it off.
    colour_split : ColourSplitParameters or None
        When a group is split where two colours lie at two depths (with a colour cue:
        :func:`group_obstacle_pixels`); ``None`` switches it off.
    coplanar_colour_reach_cells, coplanar_max_chroma_distance : int, float
        With a colour cue, groups whose mean colours lie closer than
        ``coplanar_max_chroma_distance`` in ``(a*, b*)`` (one colour: half the colour split's
        distinction) are tested for the joining up to ``coplanar_colour_reach_cells`` cells
        apart, not only in neighbouring cells (1 switches that off).
    """

    cell_px: int = 8
    min_cell_pixels: int = 6
    abs_tolerance_px: float = 1.0
    rel_tolerance: float = 0.05
    min_pure_fraction: float = 0.7
    min_object_pixels: int = 120
    far_min_fraction: float = 0.5
    far_disparity_px: float = 12.0
    far_min_width_px: int = 8
    split_tolerance_px: float = 0.5
    split_min_gap_px: float = 0.5
    split_min_step_px: float = 0.3
    coplanar_tolerance_px: float = 0.12
    coplanar_rel_tolerance: float = 0.01
    colour_split: ColourSplitParameters | None = field(default_factory=ColourSplitParameters)
    coplanar_colour_reach_cells: int = 2
    coplanar_max_chroma_distance: float = 5.0

    def __post_init__(self) -> None:
        check_integers(self, (("cell_px", 2, math.inf), ("min_object_pixels", 1, math.inf),
                              ("coplanar_colour_reach_cells", 1, 16)))
        check_integers(self, (("min_cell_pixels", 1, self.cell_px ** 2), ("far_min_width_px", 1, math.inf)))
        check_positive(self, ("abs_tolerance_px", "far_disparity_px"))
        check_numbers(self, (("rel_tolerance", 0.0, math.inf), ("min_pure_fraction", 0.0, 1.0),
                             ("split_tolerance_px", 0.0, math.inf), ("split_min_gap_px", 0.0, math.inf),
                             ("split_min_step_px", 0.0, math.inf),
                             ("coplanar_tolerance_px", 0.0, math.inf), ("coplanar_rel_tolerance", 0.0, math.inf),
                             ("coplanar_max_chroma_distance", 0.0, 400.0), ("far_min_fraction", 0.0, 1.0)))
        check_types(self, (("colour_split", ColourSplitParameters),), allow_none=True)


def _tolerance(d: np.ndarray, params: GroupingParameters) -> np.ndarray:
    return np.maximum(params.abs_tolerance_px, params.rel_tolerance * np.abs(d))


def _cell_disparities(disparity: np.ndarray, mask: np.ndarray,
                      params: GroupingParameters) -> tuple[np.ndarray, np.ndarray]:
    """Median disparity of each cell's masked valid pixels (NaN for cells with too few) and
    whether each cell is pure (``min_pure_fraction`` of its pixels agree with the median)."""
    h, w = disparity.shape
    c = params.cell_px
    gh, gw = -(-h // c), -(-w // c)
    padded = np.full((gh * c, gw * c), np.nan, dtype=np.float32)
    padded[:h, :w] = np.where(mask, disparity, np.nan)
    return cell_medians_kernel(padded, c, params.min_cell_pixels, params.abs_tolerance_px, params.rel_tolerance,
                               params.min_pure_fraction)


def _label_cells(cells: np.ndarray, pure: np.ndarray, params: GroupingParameters) -> np.ndarray:
    """Connected components of valid cells, pure cells joined where their disparities agree.

    The cells and the links between them are laid out on one grid of twice the resolution
    (cells at even positions, a link between two cells at the odd position between them), so
    that one 4-connected labelling by OpenCV finds the components.
    """
    gh, gw = cells.shape
    valid = np.isfinite(cells)
    filled = np.nan_to_num(cells)
    tol = _tolerance(filled, params)
    grid = np.zeros((2 * gh - 1, 2 * gw - 1), dtype=np.uint8)
    grid[::2, ::2] = valid
    grid[::2, 1::2] = pure[:, :-1] & pure[:, 1:] & (
        np.abs(filled[:, :-1] - filled[:, 1:]) <= np.minimum(tol[:, :-1], tol[:, 1:]))
    grid[1::2, ::2] = pure[:-1, :] & pure[1:, :] & (
        np.abs(filled[:-1, :] - filled[1:, :]) <= np.minimum(tol[:-1, :], tol[1:, :]))
    _, components = cv2.connectedComponents(grid, connectivity=4)
    labels = np.full((gh, gw), -1, dtype=np.int64)
    _, compact = np.unique(components[::2, ::2][valid], return_inverse=True)
    labels[valid] = compact
    return labels


def _raw_groups(d: np.ndarray, usable: np.ndarray, params: GroupingParameters) -> tuple[np.ndarray, np.ndarray]:
    """int64 ``(H, W)`` group of each usable pixel (-1: none) and the pixel count of each group."""
    cells, pure = _cell_disparities(d, usable, params)
    cell_labels = _label_cells(cells, pure, params)
    return assign_pixels_kernel(d, usable, cell_labels, cells, params.cell_px, params.abs_tolerance_px,
                                params.rel_tolerance, int(cell_labels.max()) + 1)


def _split_depth_layers(groups: np.ndarray, tight: np.ndarray, d: np.ndarray,
                        params: GroupingParameters) -> np.ndarray:
    """``groups`` (int64, -1: none) with each group split into the tight groups of an object's size
    it holds, when their median disparities span more than ``split_min_gap_px``; tight groups that
    meet without a step of more than ``split_min_step_px`` stay together (one slanted surface). The
    gap is tested on the tight groups' medians only, not again on the parts they form: a slanted
    surface's median says little about where it meets another (docs/pipeline.md, session 30)."""
    n_groups, n_tight = int(groups.max()) + 1, int(tight.max()) + 1
    both = (groups >= 0) & (tight >= 0)
    # pixels of each (group, tight group) pair: most frames have no group with two layers
    pair_counts = np.bincount(groups[both] * n_tight + tight[both], minlength=n_groups * n_tight)
    layered = (pair_counts.reshape(n_groups, n_tight) >= params.min_object_pixels).sum(axis=1) >= 2
    splits = GroupSplits(groups, n_groups)
    # the pixels of the layered groups, sorted by group once (row-major within each, as np.nonzero)
    labels = groups.ravel()
    members = np.flatnonzero(layered[np.maximum(labels, 0)] & (labels >= 0))
    members = members[np.argsort(labels[members], kind="stable")]
    candidates = np.flatnonzero(layered)
    bounds = np.searchsorted(labels[members], np.append(candidates, n_groups))
    for group, start, stop in zip(candidates, bounds[:-1], bounds[1:]):
        ys, xs = np.divmod(members[start:stop], groups.shape[1])
        inner, values = tight[ys, xs], d[ys, xs]
        layers = np.flatnonzero(pair_counts[group * n_tight:(group + 1) * n_tight] >= params.min_object_pixels)
        medians = np.array([np.median(values[inner == layer]) for layer in layers])
        if medians.max() - medians.min() <= params.split_min_gap_px:
            continue
        layer_of = np.searchsorted(layers, inner)  # exact for pixels in one of the layers
        in_layer = (inner >= 0) & (layers[np.minimum(layer_of, len(layers) - 1)] == inner)
        nearest = np.argmin(np.abs(values[:, None] - medians[None, :]), axis=1)
        parts = np.where(in_layer, layer_of, nearest)
        if params.split_min_step_px > 0:
            parts = layer_surfaces(ys, xs, values, np.where(in_layer, layer_of, -1), len(layers),
                                   params.split_min_step_px)[parts]
        splits.split(group, ys, xs, parts)
    return splits.groups


def object_sized(groups: np.ndarray, d: np.ndarray, counts: np.ndarray, params: GroupingParameters) -> np.ndarray:
    """``bool (n,)``: which groups hold an object's pixel count, ``min_object_pixels`` or, far
    away by their mean disparity, fewer (:class:`GroupingParameters`). ``groups`` int64 ``(H, W)``,
    ``0..n-1``, -1 for none; ``d`` the disparity (pixels), finite at every grouped pixel;
    ``counts`` ``(n,)`` the groups' pixel counts."""
    sized = counts >= params.min_object_pixels
    far = ~sized & (counts >= params.far_min_fraction * params.min_object_pixels)
    if not far.any():
        return sized
    mean_d = _group_means(groups, d, len(counts))
    # counts >= min_object_pixels * (d / far_disparity_px) ** 2, without dividing by a tiny parameter
    far &= counts * params.far_disparity_px ** 2 >= params.min_object_pixels * np.maximum(mean_d, 0.0) ** 2
    if not far.any():
        return sized
    ys, xs = np.nonzero((groups >= 0) & far[np.maximum(groups, 0)])
    group_of = groups[ys, xs]
    first, last = np.full(len(counts), groups.shape[1]), np.full(len(counts), -1)
    np.minimum.at(first, group_of, xs)
    np.maximum.at(last, group_of, xs)
    return sized | (far & (last - first + 1 >= params.far_min_width_px))


def _group_means(groups: np.ndarray, values: np.ndarray, n: int) -> np.ndarray:
    """``float64 (n,)`` (or ``(n, C)``): the mean of ``values`` (``(H, W)``, or ``(H, W, C)``) over
    each group's pixels (``groups`` int64 ``(H, W)``, ``0..n-1``, -1 for none); 0 for a group
    without pixels."""
    grouped = groups >= 0
    labels = groups[grouped]
    counts = np.maximum(np.bincount(labels, minlength=n), 1)
    picked = values[grouped] if values.ndim == 3 else values[grouped][:, None]     # (N, C)
    means = np.stack([np.bincount(labels, weights=picked[:, k], minlength=n) / counts
                      for k in range(picked.shape[1])], axis=1)
    return means[:, 0] if values.ndim == 2 else means


def group_obstacle_pixels(disparity: np.ndarray, obstacle_mask: np.ndarray,
                          params: GroupingParameters = GroupingParameters(), *,
                          colour: ColourCue | None = None,
                          calibration: StereoCalibration | None = None) -> np.ndarray:
    """Label each obstacle pixel with the object it belongs to.

    Parameters
    ----------
    disparity
        ``float32 (H, W)`` disparity in pixels, NaN where unmatched.
    obstacle_mask
        ``bool (H, W)``: pixels that phase 1 (or geometry) calls obstacle.
    params
        Grouping parameters.
    colour
        The left image's colour cue (:func:`stereo_obstacles.colour_split.colour_cue`) for the
        split along colour (``params.colour_split``) and the joining of groups of one colour a
        few cells apart (``params.coplanar_colour_reach_cells``); ``None``: neither.
    calibration
        The rig: with a colour cue, the colour split also splits a group into two depth clusters
        that stand apart on the ground (:mod:`stereo_obstacles.colour_split`); ``None``: it does not.

    Returns
    -------
    numpy.ndarray
        ``int32 (H, W)``: 0 for pixels in no object, ``1..N`` for the objects, numbered by
        decreasing size.

    Raises
    ------
    InvalidInputError
        A disparity and a mask of different shapes, or a calibration that is not a
        ``StereoCalibration``.
    """
    d = np.asarray(disparity, dtype=np.float32)
    m = np.asarray(obstacle_mask, dtype=bool)
    if d.ndim != 2 or d.shape != m.shape:
        raise InvalidInputError(f"disparity {d.shape} and obstacle_mask {m.shape} must be the same 2-D shape")
    if calibration is not None and not isinstance(calibration, StereoCalibration):
        raise InvalidInputError(f"calibration must be a StereoCalibration or None, got {type(calibration).__name__}")
    usable = m & np.isfinite(d)
    raw, counts = _raw_groups(d, usable, params)
    loose = raw
    if 0 < params.split_tolerance_px < params.abs_tolerance_px and raw.max() >= 0:
        tight, _ = _raw_groups(d, usable, replace(params, abs_tolerance_px=params.split_tolerance_px,
                                                  split_tolerance_px=0.0))
        raw = _split_depth_layers(raw, tight, d, params)
    if colour is not None and params.colour_split is not None and raw.max() >= 0:
        raw = split_groups_by_colour(raw, d, colour, min_object_pixels=params.min_object_pixels,
                                     params=params.colour_split, calibration=calibration)
    if raw is not loose:
        counts = np.bincount(raw[raw >= 0], minlength=int(raw.max()) + 1)
    if params.coplanar_tolerance_px > 0:
        sized = object_sized(raw, d, counts, params)
        sized_label = np.concatenate([[-1], np.cumsum(sized) - 1])
        sized_label[1:][~sized] = -1
        raw = sized_label[raw + 1]
        split_from = np.zeros(int(raw.max()) + 1, dtype=np.int64)
        split_from[raw[raw >= 0]] = loose[raw >= 0]            # a layer lies within one loose group
        colours = None if colour is None else _group_means(raw, colour.chroma, len(split_from))
        raw = merge_coplanar_groups(raw, d, cell_px=params.cell_px, tolerance_px=params.coplanar_tolerance_px,
                                    rel_tolerance=params.coplanar_rel_tolerance, split_from=split_from,
                                    colours=colours,
                                    colour_reach_cells=params.coplanar_colour_reach_cells,
                                    max_chroma_distance=params.coplanar_max_chroma_distance)
        counts = np.bincount(raw[raw >= 0], minlength=int(raw.max()) + 1)
    keep = np.flatnonzero(object_sized(raw, d, counts, params))
    order = keep[np.argsort(-counts[keep], kind="stable")]
    relabel = np.zeros(len(counts) + 1, dtype=np.int32)
    relabel[order + 1] = np.arange(1, len(order) + 1, dtype=np.int32)
    return relabel[raw + 1]
