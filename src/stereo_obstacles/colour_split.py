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
- each part holds an object's pixel count, and the farther one is not a rim around the nearer
  (more than ``MAX_RIM_FRACTION`` of its pixels within ``RIM_PX`` of it, and fewer than an
  object's pixel count farther than ``OBJECT_BEYOND_RIM_PX``: the halo of sky or ground the
  matching spreads around an object lies behind it; a thin part in front is an object, a pole
  before a box, and so is a farther part that holds an object beyond its rim, a box beside the
  end of a wall in front of it; with chroma clusters, the nearer part's pixels at the farther
  part's depth, at least the gap behind the nearer part's median and of a third colour, are the
  farther object's own halo and do not count as the nearer part in this test; and a farther
  chroma cluster that is a rim by these counts is still an object when it is obstacle-coloured,
  of a colour far from the nearer part's, and reaches past the rim in one piece of a quarter of
  an object's pixel count: a pole beside the end of a wall in front of it);
- their median disparities differ by more than the *gap*, ``max(min_gap_px, min_gap_rel * d)``;
- each part lies on one plane in disparity (``min_plane_fraction`` of its pixels on its robust
  plane: :func:`~stereo_obstacles.part_boundaries.on_plane_fraction`): a colour boundary
  running across a surface (lighting, a painted pattern) leaves a part of two surfaces;
- where the parts touch, their planes, fitted away from the boundary where the disparity is
  blurred, lie more than the gap apart: a step (:mod:`stereo_obstacles.part_boundaries`). The
  faces of one box differ in colour and in median disparity too, but their planes meet at the
  crease between them. A part that shows two faces itself has a plane that leans across them;
  where these planes show no step, planes fitted to a band of each part next to the boundary
  must lie more than ``NEAR_STEP_FACTOR`` times the gap apart, and then sort the pixels near it
  (:func:`~stereo_obstacles.part_boundaries.planes_near_boundary`).

Only the pixels that phase 1 calls obstacle by their colour are clustered; the others (ground
coloured, raised by their disparity: the halo at an object's foot) join the part of the nearest
clustered pixel. Connected pieces of a cluster smaller than an object join the other cluster
(texture: a brick wall's mortar); a piece is connected across a few pixels where the group has
none (unmatched, or outside it) too, so the blobs of a sparsely matched face are one piece
(:meth:`~stereo_obstacles.part_boundaries.PixelCanvas.small_pieces`). Once a split is kept, the
pixels near the boundary go to the part whose plane they fit better, and each part is tried
again, ``max_levels`` levels deep (a cylinder between two walls). A group of more than 8000
pixels is decided on one pixel of each small square
(:class:`~stereo_obstacles.part_boundaries.PixelCanvas`), each other pixel following its square's.
Measured in ``docs/pipeline.md`` ("Splitting by colour").

When a whole group holds no two chroma clusters (too few coloured pixels, centres too close, or
their medians within the gap), phase 1's own verdict is tried as the two clusters instead:
an object coloured like the ground stands only by its disparity, and is split from a coloured
object it touches by the same tests (``docs/pipeline.md``, session 25).

With a calibration, a whole group that neither splits (no two clusters, or clusters the tests
refuse) is tried once more with two *depth clusters* (a 1-D 2-means of its disparities): two
objects of one colour (grey on grey) at 7-10 m, 0.5-1 px apart, or of colours whose clusters fail
the tests. Depth clusters also cut one object along its slope or between its faces, and the tests
above let many such cuts through, so a depth split is kept only when the two parts also stand
apart on the ground, both as the 2-means cuts them and after the tests: their footprints
(:mod:`stereo_obstacles.footprints`, from all the group's pixels, also where the tests decide on
squares) have ``depth_touch_points`` points each or more, and fewer than that many of one lie
within ``depth_gap_m`` of the other (``docs/pipeline.md``, session 28). Like phase 1's verdict,
they are tried only on groups holding an object's pixel count of obstacle-coloured pixels.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from stereo_obstacles._colour_split_kernel import group_runs_kernel, two_colours_kernel
from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import check_integers, check_numbers
from stereo_obstacles.footprints import close_points, footprint
from stereo_obstacles.group_splits import GroupSplits
from stereo_obstacles.part_boundaries import (FIT_MARGIN_PX, PixelCanvas, Plane, boundary, distance_to_other,
                                              on_plane_fraction, planes_away_from_boundary, planes_near_boundary,
                                              step_at)
from stereo_obstacles.plane_fit import plane_at
from stereo_obstacles.quantiles import median

__all__ = ["ColourCue", "ColourSplitParameters", "chroma_apart", "colour_cue", "split_groups_by_colour"]

RIM_PX = 4.0
"""The farther part is a rim when more than ``MAX_RIM_FRACTION`` of its pixels lie within this
distance (pixels, at least one square of a large group's) of the nearer part, and fewer than an
object's pixel count lie farther than ``OBJECT_BEYOND_RIM_PX`` from it."""
MAX_RIM_FRACTION = 0.5
OBJECT_BEYOND_RIM_PX = 6.0
"""Pixels of the farther part farther than this (pixels; one and a half squares of a large
group's where that is more, from squares of 5 px up) from the nearer part hold an object of its
own when they are an object's pixel count: a halo up to this wide stays a rim. Counted from 4 px,
the synthetic sets had 14 more repeated detections than from 6 px; in the clean scenes that
gained a repeat over no such rule, 8 of the 19 repeating detections lay 38-50 % on the background
around their object (``docs/pipeline.md``, "What the matcher's errors cost the obstacles, and
rims that hold an object")."""
HIDDEN_OBJECT_COLOURED_FRACTION = 0.8
HIDDEN_OBJECT_CHROMA_FACTOR = 2.0
HIDDEN_OBJECT_BEYOND_FRACTION = 0.25
"""A farther chroma cluster the rim test calls a rim is a partly hidden object instead when at
least this fraction of its pixels is obstacle-coloured by phase 1 (the halos the rim test is
for hold ground-coloured pixels raised by their disparity: 59 and 67 % coloured in the two
synthetic scenes where dropping this condition split one off), its median chroma lies at least this
factor times ``min_chroma_distance`` from the nearer part's (not a face of the nearer object lit
otherwise: 11 and 13 apart), and at least this fraction of an object's pixel count lies beyond
the rim in one piece (not a band along the nearer object's outline: a near cylinder's flank had 4
pixels beyond; nor a halo, whose pixels beyond lie in its corners). The two objects mended held
86 and 96 % coloured pixels, 32 and 41 apart in chroma, 71 and 43 pixels beyond; without the one
piece, 0.85, 20 and 30 pixels, or 0.8, 15 and 20, gave the same obstacles over the five
synthetic sets as 0.8, 20 and 30 (``docs/pipeline.md``, session 37)."""
STEP_PERCENTILE = 10.0
"""Percentile of the planes' difference along the boundary that must exceed the gap: a low one,
so that planes crossing anywhere along it (a crease) do not read as a step."""
NEAR_STEP_FACTOR = 1.5
"""Where the planes fitted away from the boundary show no step, the planes nearest it
(:func:`~stereo_obstacles.part_boundaries.planes_near_boundary`) must differ by more than this
many times the gap along it: fitted to fewer pixels, they read a crease as a step more easily
(at the gap itself, scene 1263's near box split at the crease between its faces;
``docs/pipeline.md``, session 44)."""
CLUSTER_SAMPLE, MAX_CLUSTER_ROUNDS = 2000, 20
"""At most this many pixels (evenly spaced) find the two colour centres, in at most this many
rounds of 2-means; every pixel then joins the nearer centre."""
DEPTH_CLUSTER_ROUNDS, DEPTH_CLUSTER_SETTLED_PX = 30, 1e-4
"""The 1-D 2-means of the depth clusters stops after this many rounds, or when its threshold moves
by less than this (pixels of disparity)."""


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
    depth_gap_m, depth_touch_points : float, int
        With a calibration, two depth clusters split a group only where their footprints stand
        apart: each has ``depth_touch_points`` points or more, and fewer than that many of one lie
        within ``depth_gap_m`` metres of the other (module docstring). ``depth_gap_m`` 0 switches
        the depth clusters off.
    """

    blur_px: int = 5
    min_chroma_distance: float = 10.0
    min_gap_px: float = 0.3
    min_gap_rel: float = 0.03
    min_plane_fraction: float = 0.6
    max_levels: int = 2
    depth_gap_m: float = 0.3
    depth_touch_points: int = 2

    def __post_init__(self) -> None:
        check_integers(self, (("blur_px", 1, 99), ("max_levels", 1, 8), ("depth_touch_points", 1, 10 ** 6)))
        check_numbers(self, (("min_chroma_distance", 0.0, 400.0), ("min_gap_px", 0.0, math.inf),
                             ("min_gap_rel", 0.0, 1.0), ("min_plane_fraction", 0.0, 1.0),
                             ("depth_gap_m", 0.0, math.inf)))


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


def chroma_apart(chroma: np.ndarray, colour: np.ndarray, distance: float) -> np.ndarray:
    """``bool (n,)``: whether each chroma (``int32`` or ``float (n, 2)``, :attr:`ColourCue.chroma`
    values) lies at least ``distance`` from ``colour`` (``(2,)``) in ``(a*, b*)``."""
    difference = chroma - colour
    return np.einsum("nk,nk->n", difference, difference) >= distance * distance


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
                           params: ColourSplitParameters = ColourSplitParameters(),
                           calibration: StereoCalibration | None = None) -> np.ndarray:
    """Split each group that holds two colours at two depths (or, with a calibration, two depths
    that stand apart on the ground).

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
    calibration
        The rig, for the footprints of depth clusters in metres; ``None``: no depth clusters.

    Returns
    -------
    numpy.ndarray
        ``int64 (H, W)``: ``groups`` itself where nothing was split and it is ``int64``,
        otherwise a copy in which each part split off has a new label after the existing ones.

    Raises
    ------
    InvalidInputError
        ``groups``, ``disparity`` and the cue of different heights and widths,
        ``min_object_pixels`` below 1, or a calibration that is not a ``StereoCalibration``.

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
    if calibration is not None and not isinstance(calibration, StereoCalibration):
        raise InvalidInputError(f"calibration must be a StereoCalibration or None, got {type(calibration).__name__}")
    groups = groups.astype(np.int64, copy=False)
    width = groups.shape[1]
    depth_clusters = calibration is not None and params.depth_gap_m > 0
    counts, coloured_counts, starts, pixels = group_runs_kernel(
        groups.ravel(), cue.coloured.ravel(), int(groups.max(initial=-1)) + 1)
    # the first tests of _split on the counts alone (two objects' pixels, one object's coloured by
    # phase 1: the least phase 1's verdict needs): most groups need no pass over their pixels
    large = (counts >= 2 * min_object_pixels) & (coloured_counts >= min_object_pixels)
    splits = GroupSplits(groups, len(counts))
    for group in np.flatnonzero(large):
        run = pixels[starts[group]:starts[group + 1]]
        ys, xs = np.divmod(run, width)
        canvas, chosen, square_of = PixelCanvas.of_pixels(ys, xs)
        decided = run[chosen]
        d = disparity.ravel()[decided].astype(np.float64)
        if not np.isfinite(d).all():
            continue
        ground_plan = (_GroundPlan(xs, disparity.ravel()[run], square_of, calibration, params) if depth_clusters
                       else None)
        parts = _split(canvas, d, cue.chroma.reshape(-1, 2)[decided], cue.coloured.ravel()[decided],
                       min_object_pixels, params, ground_plan, params.max_levels)[square_of]
        splits.split(group, ys, xs, parts)
    return splits.groups


@dataclass(frozen=True, eq=False)
class _PixelColours:
    """The colours of a canvas's ``n`` pixels: ``chroma`` (``uint8 (n, 2)``, as in
    :class:`ColourCue`) and ``coloured`` (``bool (n,)``, obstacle-coloured by phase 1)."""

    chroma: np.ndarray
    coloured: np.ndarray


@dataclass(frozen=True, eq=False)
class _GroundPlan:
    """A whole group's pixels at full size, to compare the footprints of two parts of it whatever
    the squares its canvas decides on: ``xs`` (int64, shape (N,)) their columns, ``d`` (shape (N,),
    pixels) their disparities, ``square_of`` (int64, shape (N,)) the canvas pixel each follows."""

    xs: np.ndarray
    d: np.ndarray
    square_of: np.ndarray
    calibration: StereoCalibration
    params: ColourSplitParameters

    def stand_apart(self, cluster: np.ndarray) -> bool:
        """Whether the parts ``cluster`` 0 and 1 (``int64``, one per canvas pixel) stand apart on
        the ground: each footprint has ``depth_touch_points`` points or more (fewer say nothing),
        and fewer than that many of one lie within ``depth_gap_m`` of the other."""
        of_pixel = cluster[self.square_of]
        prints = [footprint(self.xs[of_pixel == k], self.d[of_pixel == k], self.calibration) for k in (0, 1)]
        touching = self.params.depth_touch_points
        return min(map(len, prints)) >= touching and min(close_points(*prints, self.params.depth_gap_m)) < touching


def _split(canvas: PixelCanvas, d: np.ndarray, chroma: np.ndarray, coloured: np.ndarray, min_object_pixels: int,
           params: ColourSplitParameters, ground_plan: _GroundPlan | None, levels: int) -> np.ndarray:
    """``int64 (n,)`` part of each of the canvas's ``n`` pixels (0 for all: not split), ``levels`` deep;
    ``ground_plan`` (the whole group's, at the first level only): try depth clusters too."""
    parts = np.zeros(len(d), dtype=np.int64)
    if levels == 0 or canvas.pixels() < 2 * min_object_pixels:
        return parts
    whole_group = levels == params.max_levels
    cluster = _colour_clusters(canvas, d, chroma, coloured, min_object_pixels, params)
    by_chroma = cluster is not None
    # phase 1's verdict only on a whole group without two chroma clusters: within a part split off by
    # chroma, the ground-coloured pixels follow their nearest coloured ones (the foot of a pole); and
    # tried also where the chroma clusters fail the depth tests, it split two objects more over scenes
    # 0..419 and mended none (docs/pipeline.md, session 25)
    if cluster is None and whole_group:
        cluster = _phase_one_clusters(canvas, d, coloured, min_object_pixels, params)
    if cluster is not None:
        cluster = _two_depths(canvas, d, cluster, _PixelColours(chroma, coloured) if by_chroma else None,
                              min_object_pixels, params)
    if cluster is None and ground_plan is not None:
        cluster = _depth_split(canvas, d, min_object_pixels, params, ground_plan)
    if cluster is None:
        return parts
    for k in (0, 1):
        members = np.flatnonzero(cluster == k)
        sub = _split(canvas.subset(members), d[members], chroma[members], coloured[members], min_object_pixels,
                     params, None, levels - 1)
        parts[members] = sub + (parts.max() + 1 if k else 0)
    return parts


def _colour_clusters(canvas: PixelCanvas, d: np.ndarray, chroma: np.ndarray, coloured: np.ndarray,
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
    return _without_small_pieces(canvas, cluster, min_object_pixels)


def _phase_one_clusters(canvas: PixelCanvas, d: np.ndarray, coloured: np.ndarray, min_object_pixels: int,
                        params: ColourSplitParameters) -> np.ndarray | None:
    """``int64 (n,)`` cluster 0 for the pixels phase 1 calls obstacle by their colour, 1 for the
    others (ground-coloured, raised by their disparity), or None when either holds fewer than an
    object's pixels or their median disparities do not differ by more than the gap.

    Phase 1's verdict is a colour cue of its own: an object coloured like the ground stands only
    by its disparity, so it has no chroma cluster of its own and joins whatever coloured object
    it touches (a brick box beside a green wall, 1.3 px apart, was reported at the box's
    distance for both)."""
    if min(canvas.pixels(coloured), canvas.pixels(~coloured)) < min_object_pixels:
        return None
    apart, gap = _median_gap(d, coloured, ~coloured, params)
    if apart <= gap:        # the cheap test first (the split tests it again once the pieces have moved)
        return None
    return _without_small_pieces(canvas, (~coloured).astype(np.int64), min_object_pixels)


def _depth_split(canvas: PixelCanvas, d: np.ndarray, min_object_pixels: int, params: ColourSplitParameters,
                 ground_plan: _GroundPlan) -> np.ndarray | None:
    """``int64 (n,)`` cluster 0 (nearer) or 1 (farther) of each pixel when the pixels' two depth
    clusters are two surfaces at two depths (:func:`_two_depths`) that stand apart on the ground,
    both as the 2-means cuts them and once the pixels near the boundary have moved to the plane
    they fit (module docstring); else None."""
    threshold = d.mean()           # not the median: more than half the pixels may share it
    for _ in range(DEPTH_CLUSTER_ROUNDS):
        farther = d < threshold
        if farther.all() or not farther.any():
            return None
        moved = 0.5 * (d[farther].mean() + d[~farther].mean())
        if abs(moved - threshold) < DEPTH_CLUSTER_SETTLED_PX:
            break
        threshold = moved
    cluster = (d < threshold).astype(np.int64)
    # the footprints first, the cheaper test: most groups are one surface, whose clusters touch
    if not ground_plan.stand_apart(cluster):
        return None
    cluster = _without_small_pieces(canvas, cluster, min_object_pixels)
    if cluster is not None:
        cluster = _two_depths(canvas, d, cluster, None, min_object_pixels, params)
    return cluster if cluster is not None and ground_plan.stand_apart(cluster) else None


def _without_small_pieces(canvas: PixelCanvas, cluster: np.ndarray, min_object_pixels: int) -> np.ndarray | None:
    """``cluster`` (``int64 (n,)``, 0 or 1) with each connected piece smaller than an object moved
    to the other cluster; None when a cluster is then smaller than an object."""
    for k in (0, 1):
        cluster[canvas.small_pieces(cluster == k, min_object_pixels)] = 1 - k
    if min(canvas.pixels(cluster == 0), canvas.pixels(cluster == 1)) < min_object_pixels:
        return None
    return cluster


def _median_gap(d: np.ndarray, first: np.ndarray, second: np.ndarray,
                params: ColourSplitParameters) -> tuple[float, float]:
    """How far apart (pixels) the median disparities of the pixels ``first`` and ``second`` are
    (``bool (n,)``), and the gap they must exceed, ``max(min_gap_px, min_gap_rel * d)`` at the
    larger median; ``(0, min_gap_px)`` when either holds no pixel (a 2-means stopped by its round
    limit can leave a coloured cluster empty)."""
    if not (first.any() and second.any()):
        return 0.0, params.min_gap_px
    return _gap(median(d[first]), median(d[second]), params)


def _gap(first_median: float, second_median: float, params: ColourSplitParameters) -> tuple[float, float]:
    """How far apart (pixels) two median disparities are, and the gap they must exceed,
    ``max(min_gap_px, min_gap_rel * d)`` at the larger one."""
    return (abs(first_median - second_median),
            max(params.min_gap_px, params.min_gap_rel * max(first_median, second_median)))


def _two_depths(canvas: PixelCanvas, d: np.ndarray, cluster: np.ndarray, colours: _PixelColours | None,
                min_object_pixels: int, params: ColourSplitParameters) -> np.ndarray | None:
    """``cluster`` with the pixels near the boundary moved to the part whose plane they fit
    better (the planes that showed the step: :func:`_planes_with_step`), when the two clusters
    are two surfaces at two depths (module docstring) and each still holds an object's pixel
    count; else None. ``colours``: the pixels' colours when the clusters are chroma clusters, for
    the rim test (:func:`_distance_to_nearer`, :func:`_partly_hidden_object`); None for phase 1's
    verdict and for depth clusters."""
    second = cluster == 1
    if second.all() or not second.any():
        return None
    medians = median(d[~second]), median(d[second])
    apart, gap = _gap(*medians, params)
    if apart <= gap:
        return None
    to_other = distance_to_other(canvas, second)
    farther = second if medians[1] < medians[0] else ~second
    chroma = colours.chroma if colours is not None else None
    to_nearer = _distance_to_nearer(canvas, d, farther, min(medians), max(medians), chroma, to_other, gap, params)
    rim = farther & (to_nearer <= max(RIM_PX, canvas.block))                        # next square at least
    beyond = farther & (to_nearer > max(OBJECT_BEYOND_RIM_PX, 1.5 * canvas.block))
    if (canvas.pixels(rim) > MAX_RIM_FRACTION * canvas.pixels(farther) and canvas.pixels(beyond) < min_object_pixels
            and not _partly_hidden_object(canvas, farther, beyond, colours, min_object_pixels, params)):
        return None
    planes = planes_away_from_boundary(canvas, d, second, to_other)
    if planes is None:
        return None
    if min(on_plane_fraction(canvas, d, members, plane) for members, plane in zip((~second, second), planes)) < (
            params.min_plane_fraction):
        return None
    touching = boundary(canvas, to_other)
    if touching is not None:
        planes = _planes_with_step(canvas, d, second, to_other, touching, planes, gap)
        if planes is None:
            return None
    near = to_other <= FIT_MARGIN_PX
    residual = [np.abs(d - plane_at(plane, canvas.xs, canvas.ys)) for plane in planes]
    cluster = np.where(near, residual[1] < residual[0], cluster).astype(np.int64)
    return cluster if min(canvas.pixels(cluster == 0), canvas.pixels(cluster == 1)) >= min_object_pixels else None


def _planes_with_step(canvas: PixelCanvas, d: np.ndarray, second: np.ndarray, to_other: np.ndarray,
                      touching: np.ndarray, planes: tuple[Plane, Plane], gap: float) -> tuple[Plane, Plane] | None:
    """The planes of the parts (``second``: ``bool (n,)``, the second part's pixels) that show a
    step along the boundary pixels ``touching``: ``planes``, fitted away from the boundary, when
    they lie more than ``gap`` pixels apart there; else the planes near the boundary
    (:func:`~stereo_obstacles.part_boundaries.planes_near_boundary`) when they lie more than
    ``NEAR_STEP_FACTOR`` times the gap apart; None when neither do (a crease)."""
    if step_at(canvas, touching, planes, STEP_PERCENTILE) > gap:
        return planes
    near = planes_near_boundary(canvas, d, second, to_other, planes)
    return near if step_at(canvas, touching, near, STEP_PERCENTILE) > NEAR_STEP_FACTOR * gap else None


def _partly_hidden_object(canvas: PixelCanvas, farther: np.ndarray, beyond: np.ndarray,
                          colours: _PixelColours | None, min_object_pixels: int, params: ColourSplitParameters) -> bool:
    """Whether the farther of two chroma clusters (``farther``, ``bool (n,)``), which the rim test
    calls a rim, is an object partly hidden behind the nearer one or standing beside it:
    obstacle-coloured, of a colour far from the nearer part's, and reaching past the rim in one
    piece of at least a set fraction of an object's pixel count (``beyond``, ``bool (n,)``: its
    pixels farther from the nearer part than the rim test's ``OBJECT_BEYOND_RIM_PX``; the pieces
    are :meth:`~stereo_obstacles.part_boundaries.PixelCanvas.small_pieces`'s, counted in
    full-size pixels), as ``HIDDEN_OBJECT_COLOURED_FRACTION`` and the constants after it say. A red
    pole at 9.1 m beside the end of a brick wall at 8.6 m lies along the wall's outline, 76 % of it
    within 4 px, and read -6.8 % merged with the wall; a blue box 1.3 m behind a grey one, -14.3 %
    (``docs/pipeline.md``, session 37). A halo's pixels beyond the rim lie in its corners, in
    pieces. False when the clusters are not chroma clusters (``colours`` None)."""
    if colours is None:
        return False
    if canvas.pixels(farther & colours.coloured) < HIDDEN_OBJECT_COLOURED_FRACTION * canvas.pixels(farther):
        return False
    far_colour, near_colour = (np.median(colours.chroma[members], axis=0) for members in (farther, ~farther))
    if math.dist(far_colour, near_colour) < HIDDEN_OBJECT_CHROMA_FACTOR * params.min_chroma_distance:
        return False
    least_piece = math.ceil(HIDDEN_OBJECT_BEYOND_FRACTION * min_object_pixels)
    return canvas.pixels(beyond & ~canvas.small_pieces(beyond, least_piece)) >= least_piece


def _distance_to_nearer(canvas: PixelCanvas, d: np.ndarray, farther: np.ndarray, far_median: float,
                        near_median: float, chroma: np.ndarray | None, to_other: np.ndarray, gap: float,
                        params: ColourSplitParameters) -> np.ndarray:
    """``float32 (n,)``: for each pixel of the farther of two parts (``farther``, ``bool (n,)``;
    the parts' median disparities ``far_median`` and ``near_median``, pixels; ``d``, ``float64
    (n,)``, the pixels' disparities), its distance (full-size pixels) to the nearer part as the
    rim test measures it; for the nearer part's pixels the value means nothing. The planes and
    the boundary of the split keep ``to_other``.

    That is ``to_other`` (``float32 (n,)``, full-size pixels: each pixel's distance to the other
    part), unless the nearer part holds the farther object's *halo*. The matching spreads a farther
    object's disparity over its surroundings, and where those cluster with the nearer part by colour
    they ring the farther object, which then reads as a rim (a brown box 1.3 m behind a cyan one,
    the sea around it clustered with the cyan box: ``docs/pipeline.md``, session 36). The halo is
    the nearer part's pixels no more than ``gap`` (pixels of disparity) in front of the farther
    median (or behind it) and at least ``gap`` behind their own part's, when it is of a third
    colour: the median chromas (``chroma``, ``uint8 (n, 2)``) of the farther part, of the halo and
    of the rest of the nearer part lie at least ``min_chroma_distance`` apart, each from each. The
    distances are then measured to the rest. Pixels at that depth of the nearer part's own colour
    are its receding flank (a cylinder's side) and count; a farther part of the rest's colour is a
    piece of the nearer object (a near cylinder's flank, its colour shifted by the light), and so is
    measured to all of it. ``chroma`` None (clusters that are not chroma clusters): ``to_other``."""
    if chroma is None:
        return to_other
    halo = ~farther & (d <= min(far_median + gap, near_median - gap))
    if not halo.any():
        return to_other
    rest = ~farther & ~halo
    colours = [np.median(chroma[members], axis=0) for members in (farther, halo, rest)]
    if min(math.dist(colours[i], colours[j]) for i, j in ((0, 1), (0, 2), (1, 2))) < params.min_chroma_distance:
        return to_other
    return canvas.distance_to(rest)
