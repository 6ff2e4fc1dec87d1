"""Splitting obstacle groups where two colours lie at two depths.

Two objects a little apart in depth that touch in the image (a pole 0.6 m in front of a box at
9 m: 0.56 px of disparity; a cylinder between two walls 1 px behind it) come out of the grouping
(:mod:`stereo_obstacles.obstacle_grouping`) as one group: the matching blurs the step between
them over one or two 8 x 8 cells, which every test on cells reads as a slope, and the group is
then reported at the nearer object's distance. Their colours usually differ, though, and colour
is not blurred by the matching. So a group of at least twice an object's size is divided into
two colour clusters, and the division is kept only when the disparities, too, say that the
clusters are two surfaces at two depths:

- the cluster centres lie at least ``min_chroma_distance`` apart in the chroma ``(a*, b*)`` of
  CIE L*a*b* (lightness is left out: the lit and the shaded faces of one box differ in it);
- each part holds an object's pixel count and is not a rim around the other (at most
  ``MAX_RIM_FRACTION`` of its pixels within ``RIM_PX`` of it: the halo of sky or ground the
  matching spreads around an object);
- their median disparities differ by more than the *gap*, ``max(min_gap_px, min_gap_rel * d)``;
- each part lies on one plane in disparity (``min_plane_fraction`` of its pixels within
  ``PLANE_TOLERANCE_PX + PLANE_TOLERANCE_REL * d`` of its robust plane): a colour boundary
  running across a surface (lighting, a painted pattern) leaves a part of two surfaces;
- where the parts touch, their planes, fitted away from the boundary where the disparity is
  blurred, lie more than the gap apart (``STEP_PERCENTILE`` over the pixels along the
  boundary): a step. The faces of one box differ in colour and in median disparity too, but
  their planes meet at the crease between them.

Only the pixels that phase 1 calls obstacle by their colour are clustered; the others (ground
coloured, raised by their disparity: the halo at an object's foot) join the part of the nearest
clustered pixel. Connected pieces of a cluster smaller than an object join the other cluster
(texture: a brick wall's mortar). Once a split is kept, the pixels near the boundary go to the
part whose plane they fit better, and each part is tried again, ``max_levels`` levels deep (a
cylinder between two walls). Measured in ``docs/pipeline.md`` ("Splitting by colour").
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import cv2
import numpy as np

from stereo_obstacles._colour_split_kernel import group_runs_kernel, one_per_block_kernel, two_colours_kernel
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import check_integers, check_numbers
from stereo_obstacles.plane_fit import least_squares_plane
from stereo_obstacles.quantiles import MAD_TO_SIGMA, median, percentile

__all__ = ["ColourCue", "ColourSplitParameters", "colour_cue", "split_groups_by_colour"]

RIM_PX = 4.0
"""A part is a rim when more than ``MAX_RIM_FRACTION`` of its pixels lie within this distance
(pixels, at least one square of a large group's: ``MAX_DECISION_PIXELS``) of the other part."""
MAX_RIM_FRACTION = 0.5
BOUNDARY_PX = 2.0
"""Pixels within this distance (at least one square) of the other part are where the two parts
touch."""
FIT_MARGIN_PX = 8.0
"""Each part's plane is fitted to its pixels farther than this from the other part (the 5 x 5
windows matched at half size blur a step over about this width), and the pixels nearer than it
join the part whose plane they fit better once a split is kept."""
STEP_PERCENTILE = 10.0
"""Percentile of the distance between the two planes over the boundary pixels taken as the
step: low, so that planes crossing anywhere along the boundary (a crease) read as no step."""
PLANE_TOLERANCE_PX, PLANE_TOLERANCE_REL = 0.5, 0.02
"""A pixel lies on a plane when its disparity is within ``PLANE_TOLERANCE_PX + PLANE_TOLERANCE_REL
* d`` pixels of it."""
ROBUST_PLANE_ROUNDS, PLANE_SAMPLE = 3, 4000
"""Least-squares fits of a robust plane, each dropping the pixels farther from the previous one
than ``max(ROBUST_FLOOR_PX, ROBUST_DEVIATIONS`` robust standard deviations), on at most this
many pixels (evenly spaced)."""
ROBUST_FLOOR_PX, ROBUST_DEVIATIONS = 0.3, 2.5
MIN_TOUCHING_PIXELS = 10
"""Parts with fewer decided pixels (one per square in a large group) along their boundary do not
touch: only their median disparities and their planes are tested."""
MIN_FIT_PIXELS = 30
"""A part with fewer decided pixels away from the boundary has its plane fitted to all of them."""
MAX_DECISION_PIXELS = 8000
"""A larger group of ``n`` pixels is split on one pixel of each ``s`` x ``s`` square, ``s =
ceil(sqrt(n / MAX_DECISION_PIXELS))``, standing for the square's pixels of the group (in the
pixel counts), each other pixel following its square's."""
CLUSTER_SAMPLE, MAX_CLUSTER_ROUNDS = 2000, 20
"""At most this many pixels (evenly spaced) find the two colour centres, in at most this many
rounds of 2-means; every pixel then joins the nearer centre."""


@dataclass(frozen=True)
class ColourSplitParameters:
    """When a group is split along colour (see the module docstring).

    Attributes
    ----------
    blur_px : int
        Side of the box filter over the left image before its chroma is taken (texture and
        noise average out; 1 leaves it sharp).
    min_chroma_distance : float
        The two colour centres must lie this far apart in ``(a*, b*)`` (CIE L*a*b* units).
    min_gap_px, min_gap_rel : float
        The parts' median disparities, and their planes where they touch, must differ by more
        than ``max(min_gap_px, min_gap_rel * d)`` pixels.
    min_plane_fraction : float
        Fraction of each part's pixels that must lie on its plane.
    max_levels : int
        Levels of splitting: 1 splits a group in two at most, 2 splits each part once more.
    """

    blur_px: int = 5
    min_chroma_distance: float = 10.0
    min_gap_px: float = 0.3
    min_gap_rel: float = 0.03
    min_plane_fraction: float = 0.7
    max_levels: int = 2

    def __post_init__(self) -> None:
        check_integers(self, (("blur_px", 1, 99), ("max_levels", 1, 8)))
        check_numbers(self, (("min_chroma_distance", 0.0, 400.0), ("min_gap_px", 0.0, math.inf),
                             ("min_gap_rel", 0.0, 1.0), ("min_plane_fraction", 0.0, 1.0)))


@dataclass(frozen=True, eq=False)
class ColourCue:
    """What the split reads of the left image.

    Attributes
    ----------
    chroma
        ``uint8 (H, W, 2)``: ``a* + 128`` and ``b* + 128`` of the blurred image (OpenCV's 8-bit
        L*a*b*).
    coloured
        ``bool (H, W)``: pixels phase 1 calls obstacle by their colour.
    """

    chroma: np.ndarray
    coloured: np.ndarray

    def __post_init__(self) -> None:
        chroma, coloured = np.asarray(self.chroma), np.asarray(self.coloured)
        if chroma.dtype != np.uint8 or chroma.ndim != 3 or chroma.shape[2] != 2:
            raise InvalidInputError(f"chroma must be uint8 (H, W, 2), got {chroma.dtype} {chroma.shape}")
        if coloured.dtype != bool or coloured.shape != chroma.shape[:2]:
            raise InvalidInputError(f"coloured must be bool {chroma.shape[:2]}, got {coloured.dtype} {coloured.shape}")


def colour_cue(left: np.ndarray, coloured: np.ndarray, params: ColourSplitParameters) -> ColourCue:
    """The :class:`ColourCue` of ``uint8 (H, W, 3)`` RGB ``left`` and the ``bool (H, W)`` mask
    ``coloured``.

    Raises
    ------
    InvalidInputError
        ``left`` not ``uint8 (H, W, 3)``, or ``coloured`` of another height and width.
    """
    if left.dtype != np.uint8 or left.ndim != 3 or left.shape[2] != 3:
        raise InvalidInputError(f"left must be uint8 (H, W, 3), got {left.dtype} {left.shape}")
    if np.shape(coloured) != left.shape[:2]:
        raise InvalidInputError(f"coloured {np.shape(coloured)} must have the image's shape {left.shape[:2]}")
    blurred = cv2.blur(left, (params.blur_px, params.blur_px)) if params.blur_px > 1 else left
    lab = cv2.cvtColor(np.ascontiguousarray(blurred), cv2.COLOR_RGB2Lab)
    return ColourCue(chroma=np.ascontiguousarray(lab[..., 1:]), coloured=np.asarray(coloured, dtype=bool))


def split_groups_by_colour(groups: np.ndarray, disparity: np.ndarray, cue: ColourCue, *, min_object_pixels: int,
                           params: ColourSplitParameters = ColourSplitParameters()) -> np.ndarray:
    """Split each group that holds two colours at two depths.

    Parameters
    ----------
    groups
        ``int (H, W)`` group of each pixel, -1 for none.
    disparity
        ``float32 (H, W)`` disparity in pixels, finite at every grouped pixel (a group with a
        pixel that is not is left whole).
    cue
        The left image's :class:`ColourCue`, of the same height and width.
    min_object_pixels
        An object's pixel count (at least 1): smaller groups, parts and connected pieces are not
        split off.
    params
        When to split.

    Returns
    -------
    numpy.ndarray
        ``int64 (H, W)``: ``groups`` itself where nothing was split and it is ``int64``,
        otherwise a copy in which each part split off has a new label after the existing ones.

    Raises
    ------
    InvalidInputError
        ``groups``, ``disparity`` and the cue of different heights and widths, or
        ``min_object_pixels`` below 1.

    Examples
    --------
    A blue pole 0.6 px in front of a brown box, grouped as one:

    >>> groups = np.full((80, 120), -1); groups[30:, 20:100] = 0; groups[:, 53:67] = 0
    >>> d = np.where(groups == 0, np.float32(7.0), np.nan).astype(np.float32); d[:, 53:67] = 7.6
    >>> chroma = np.full((80, 120, 2), 128, np.uint8); chroma[groups == 0] = (150, 150)
    >>> chroma[:, 53:67] = (128, 100)
    >>> split = split_groups_by_colour(groups, d, ColourCue(chroma, groups == 0), min_object_pixels=120)
    >>> sorted({int(split[0, 60]), int(split[50, 30])})            # the pole and the box: two groups
    [0, 1]
    """
    groups = np.asarray(groups)
    if groups.ndim != 2 or np.shape(disparity) != groups.shape or cue.chroma.shape[:2] != groups.shape:
        raise InvalidInputError(f"groups {groups.shape}, disparity {np.shape(disparity)} and colour cue "
                                f"{cue.chroma.shape[:2]} must have one 2-D shape")
    if not (isinstance(min_object_pixels, (int, np.integer)) and min_object_pixels >= 1):
        raise InvalidInputError(f"min_object_pixels must be an integer >= 1, got {min_object_pixels!r}")
    groups = groups.astype(np.int64, copy=False)
    width = groups.shape[1]
    counts, coloured_counts, starts, pixels = group_runs_kernel(
        groups.ravel(), cue.coloured.ravel(), int(groups.max(initial=-1)) + 1)
    # the first tests of _split on the counts alone: most groups need no pass over their pixels
    large = (counts >= 2 * min_object_pixels) & (coloured_counts >= 2 * min_object_pixels)
    out, next_label = groups, len(counts)
    for group in np.flatnonzero(large):
        run = pixels[starts[group]:starts[group + 1]]
        ys, xs = np.divmod(run, width)
        block = max(1, math.ceil(math.sqrt(len(run) / MAX_DECISION_PIXELS)))
        chosen, square_of = _one_per_block(ys, xs, block)
        decided = run[chosen]
        d = disparity.ravel()[decided].astype(np.float64)
        if not np.isfinite(d).all():
            continue
        canvas = _Canvas(ys[chosen], xs[chosen], block, np.bincount(square_of, minlength=len(chosen)))
        parts = _split(canvas, d, cue.chroma.reshape(-1, 2)[decided], cue.coloured.ravel()[decided],
                       min_object_pixels, params, params.max_levels)[square_of]
        n_parts = int(parts.max()) + 1
        if n_parts == 1:
            continue
        if out is groups:
            out = groups.copy()
        new_labels = np.concatenate([[group], np.arange(next_label, next_label + n_parts - 1)])
        out[ys, xs] = new_labels[parts]
        next_label += n_parts - 1
    return out


class _Canvas:
    """Pixels ``(ys, xs)``, one per ``block`` x ``block`` square, each standing for ``weights``
    pixels of its square, on the image of their bounding box in squares, for image operations
    on them; distances and pixel counts in full-size pixels."""

    def __init__(self, ys: np.ndarray, xs: np.ndarray, block: int, weights: np.ndarray) -> None:
        self.ys, self.xs, self.block, self.weights = ys, xs, block, weights

    @functools.cached_property
    def _grid(self) -> tuple[np.ndarray, np.ndarray, tuple[int, int]]:
        """Each pixel's square row and column from the box's corner, and the box's shape in squares."""
        rows, columns = self.ys // self.block, self.xs // self.block
        rows, columns = rows - rows.min(), columns - columns.min()
        return rows, columns, (int(rows.max()) + 1, int(columns.max()) + 1)

    def subset(self, index: np.ndarray) -> _Canvas:
        """The canvas of the pixels ``index`` (an index array into these)."""
        return _Canvas(self.ys[index], self.xs[index], self.block, self.weights[index])

    def pixels(self, where: np.ndarray | None = None) -> int:
        """Full-size pixels that these (where ``where``, ``bool (n,)``, holds) stand for."""
        return int(self.weights.sum() if where is None else self.weights[where].sum())

    def distance_to(self, where: np.ndarray) -> np.ndarray:
        """``float32 (n,)`` distance (full-size pixels) of each pixel to the nearest pixel where
        ``where`` (``bool (n,)``) holds; large where none does."""
        rows, columns, shape = self._grid
        free = np.full(shape, 255, dtype=np.uint8)
        free[rows[where], columns[where]] = 0
        return cv2.distanceTransform(free, cv2.DIST_L2, 3)[rows, columns] * self.block

    def small_pieces(self, where: np.ndarray, min_pixels: int) -> np.ndarray:
        """``bool (n,)``: pixels where ``where`` holds in 8-connected pieces standing for fewer
        than ``min_pixels`` full-size pixels."""
        rows, columns, shape = self._grid
        image = np.zeros(shape, dtype=np.uint8)
        image[rows[where], columns[where]] = 1
        n_pieces, pieces, _, _ = cv2.connectedComponentsWithStats(image, connectivity=8)
        piece_of = pieces[rows, columns]
        small = np.bincount(piece_of[where], weights=self.weights[where], minlength=n_pieces) < min_pixels
        small[0] = False
        return where & small[piece_of]


def _one_per_block(ys: np.ndarray, xs: np.ndarray, block: int) -> tuple[np.ndarray, np.ndarray]:
    """Indices of one pixel in each ``block`` x ``block`` square holding any of the pixels
    ``(ys, xs)`` (the first), and the index into those of each pixel's square (with ``block`` 1:
    every pixel, which also compiles the kernel in :func:`stereo_obstacles.pipeline.warm_up`)."""
    rows, columns = ys // block, xs // block
    return one_per_block_kernel(rows - rows.min(), columns - columns.min())


def _split(canvas: _Canvas, d: np.ndarray, chroma: np.ndarray, coloured: np.ndarray, min_object_pixels: int,
           params: ColourSplitParameters, levels: int) -> np.ndarray:
    """``int64 (n,)`` part of each of the canvas's ``n`` pixels (0 for all: not split), ``levels`` deep."""
    parts = np.zeros(len(d), dtype=np.int64)
    if levels == 0 or canvas.pixels() < 2 * min_object_pixels:
        return parts
    cluster = _colour_clusters(canvas, d, chroma, coloured, min_object_pixels, params)
    if cluster is None:
        return parts
    cluster = _two_depths(canvas, d, cluster, min_object_pixels, params)
    if cluster is None:
        return parts
    for k in (0, 1):
        members = np.flatnonzero(cluster == k)
        sub = _split(canvas.subset(members), d[members], chroma[members], coloured[members], min_object_pixels,
                     params, levels - 1)
        parts[members] = sub + (parts.max() + 1 if k else 0)
    return parts


def _colour_clusters(canvas: _Canvas, d: np.ndarray, chroma: np.ndarray, coloured: np.ndarray,
                     min_object_pixels: int, params: ColourSplitParameters) -> np.ndarray | None:
    """``int64 (n,)`` cluster 0 or 1 of each pixel, or None when the pixels do not fall into two
    distinct colours of an object's size each, whose coloured pixels' median disparities differ
    by more than the gap."""
    if canvas.pixels(coloured) < 2 * min_object_pixels:
        return None
    centres, cluster = two_colours_kernel(chroma, coloured, CLUSTER_SAMPLE, MAX_CLUSTER_ROUNDS)
    if not math.dist(centres[0], centres[1]) >= params.min_chroma_distance:      # NaN: no spread
        return None
    apart, gap = _median_gap(d, coloured & (cluster == 0), coloured & (cluster == 1), params)
    if apart <= gap:
        return None
    if not coloured.all():
        nearest = [canvas.distance_to(coloured & (cluster == k)) for k in (0, 1)]
        cluster = np.where(coloured, cluster, nearest[1] < nearest[0]).astype(np.int64)
    for k in (0, 1):
        cluster[canvas.small_pieces(cluster == k, min_object_pixels)] = 1 - k
    if min(canvas.pixels(cluster == 0), canvas.pixels(cluster == 1)) < min_object_pixels:
        return None
    return cluster


def _median_gap(d: np.ndarray, first: np.ndarray, second: np.ndarray,
                params: ColourSplitParameters) -> tuple[float, float]:
    """How far apart (pixels) the median disparities of the pixels ``first`` and ``second`` are
    (``bool (n,)``, some pixels each), and the gap they must exceed, ``max(min_gap_px,
    min_gap_rel * d)`` at the larger median."""
    medians = median(d[first]), median(d[second])
    return abs(medians[0] - medians[1]), max(params.min_gap_px, params.min_gap_rel * max(medians))


def _two_depths(canvas: _Canvas, d: np.ndarray, cluster: np.ndarray, min_object_pixels: int,
                params: ColourSplitParameters) -> np.ndarray | None:
    """``cluster`` with the pixels near the boundary moved to the part whose plane they fit
    better, when the two clusters are two surfaces at two depths (module docstring) and each
    still holds an object's pixel count; else None."""
    apart, gap = _median_gap(d, cluster == 0, cluster == 1, params)
    if apart <= gap:
        return None
    to_part = [canvas.distance_to(cluster == k) for k in (0, 1)]
    to_other = np.where(cluster == 0, to_part[1], to_part[0])
    planes = []
    for k in (0, 1):
        members = cluster == k
        rim = members & (to_other <= max(RIM_PX, canvas.block))                    # next square at least
        if canvas.pixels(rim) > MAX_RIM_FRACTION * canvas.pixels(members):
            return None
        inner = members & (to_other > FIT_MARGIN_PX)
        fitted = inner if np.count_nonzero(inner) >= MIN_FIT_PIXELS else members
        plane = _robust_plane(canvas.xs[fitted], canvas.ys[fitted], d[fitted])
        if plane is None:
            return None
        on_plane = np.abs(d[members] - _plane_at(plane, canvas.xs[members], canvas.ys[members])) <= (
            PLANE_TOLERANCE_PX + PLANE_TOLERANCE_REL * np.abs(d[members]))
        if on_plane.mean() < params.min_plane_fraction:
            return None
        planes.append(plane)
    boundary = to_other <= max(BOUNDARY_PX, canvas.block)                   # next square at least
    if np.count_nonzero(boundary) >= MIN_TOUCHING_PIXELS:
        xs, ys = canvas.xs[boundary], canvas.ys[boundary]
        step = percentile(np.abs(_plane_at(planes[0], xs, ys) - _plane_at(planes[1], xs, ys)), STEP_PERCENTILE)
        if step <= gap:
            return None
    near = to_other <= FIT_MARGIN_PX
    residual = [np.abs(d - _plane_at(plane, canvas.xs, canvas.ys)) for plane in planes]
    cluster = np.where(near, residual[1] < residual[0], cluster).astype(np.int64)
    return cluster if min(canvas.pixels(cluster == 0), canvas.pixels(cluster == 1)) >= min_object_pixels else None


def _plane_at(plane: tuple[float, float, float], xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """The plane's disparity ``a x + b y + c`` (pixels) at columns ``xs`` and rows ``ys``."""
    a, b, c = plane
    return a * xs + b * ys + c


def _robust_plane(xs: np.ndarray, ys: np.ndarray, d: np.ndarray) -> tuple[float, float, float] | None:
    """Plane ``d = a x + b y + c`` of the pixels (at most ``PLANE_SAMPLE`` evenly spaced ones),
    refitted ``ROBUST_PLANE_ROUNDS`` times without the ones off it; None when they do not pin a
    plane down."""
    every = -(-len(d) // PLANE_SAMPLE)
    xs, ys, d = xs[::every], ys[::every], d[::every]
    kept = np.ones(len(d), dtype=bool)
    for _ in range(ROBUST_PLANE_ROUNDS):
        plane = least_squares_plane(xs[kept], ys[kept], d[kept])
        if plane is None:
            return None
        residual = np.abs(d - _plane_at(plane, xs, ys))
        kept = residual <= max(ROBUST_FLOOR_PX, ROBUST_DEVIATIONS * MAD_TO_SIGMA * median(residual[kept]))
        if np.count_nonzero(kept) < MIN_FIT_PIXELS:
            return None
    return least_squares_plane(xs[kept], ys[kept], d[kept])
