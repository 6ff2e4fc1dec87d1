"""A strip of another colour in an obstacle, matched again with windows of its own colour.

A farther object seen in a strip narrower than the matching window beside a nearer one (the end
of a box peeking out 5-10 px wide beside a wall) is matched at the nearer object's disparity:
every 5 x 5 window on the strip holds part of the nearer object, whose texture decides the
match, and the strip is grouped with it (``docs/pipeline.md``, session 40: scene 881's box at
7.39 m reported at the wall's 3.55 m). The fattened-fringe test
(:mod:`stereo_obstacles.fattened_fringes`) cannot take it out: no farther obstacle of its colour
is there to recognise it, since all of the strip's matches are the nearer one's.

Here each *piece* of an obstacle (connected, ``min_pixels`` or more) that phase 1 calls obstacle
and whose chroma lies at least ``min_foreign_chroma`` from the obstacle's median chroma is
widened to its *strip*: the pixels of its colour connected to it, its unmatched pixels too. The
strip is matched again with windows whose pixels weigh by their likeness to the centre's colour
in each image (adaptive support weights,
:func:`stereo_obstacles._own_colour_kernel.own_colour_best_kernel`): the nearer object's pixels
then hardly count. When at least ``min_agreeing`` of the confident matches of up to
``max_tested`` of its pixels agree (within ``agree_px``) on a disparity at least ``max(min_step_px,
min_step_rel * d)`` below the piece's median disparity ``d``, the strip lies farther: its pixels
that agree are re-matched there, and the strip's pixels that the obstacle holds leave it, but
those that match confidently where they are (a strip may hold a few pixels of the obstacle's own
surface whose blurred colour it tinted). The caller groups the re-matched pixels; with an object's pixel
count they are an obstacle of their own.

A first look at a third of the tested pixels leaves out most strips (81 % over scenes 0..959,
none of those that move), and the right camera's cover is asked only of strips enough of whose
matches lie farther: the stage costs a median 5 ms a 640 x 480 pair and 75 ms on KITTI 000005,
whose objects of several colours hold some 200 pieces (``docs/pipeline.md``, sessions 40-41).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from stereo_obstacles._own_colour_kernel import own_colour_best_kernel, right_cover_rows_kernel
from stereo_obstacles.colour_split import ColourSplitParameters, chroma_apart
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.fattened_fringes import FringeParameters
from stereo_obstacles.field_checks import check_integers, check_numbers, check_positive
from stereo_obstacles.labels import Label
from stereo_obstacles.obstacle_grouping import GroupingParameters, object_sized
from stereo_obstacles.obstacles import Obstacle, ObstacleList, obstacle_pixels
from stereo_obstacles.visibility import VisibilityParameters

EXCLUSION_PX = 2
"""Whole disparities on either side of the best match left out of its runner-up."""

__all__ = ["OwnColourParameters", "compile_cover", "moved_groups", "own_colour_matches"]


@dataclass(frozen=True)
class OwnColourParameters:
    """Which pieces of an obstacle are matched again, and when their new match is taken.

    Attributes
    ----------
    min_foreign_chroma : float
        Least distance in ``(a*, b*)`` of a piece's pixels from their obstacle's median chroma
        (the colour cue's, blurred 5 x 5): the colour split's ``min_chroma_distance``, below which
        two colours are one. Half the fattened fringes' threshold: the blur mixes a strip 5 px
        wide with the obstacle beside it (scene 881's: 18 from the wall's, median).
    min_pixels : int
        Least size of a connected piece (pixels), as the fattened fringes'.
    max_same_chroma : float
        The strip of a piece: the pixels connected to it whose ``(a*, b*)`` (unblurred) lies within
        this of the piece's median.
    reach_px : int
        The strip reaches at most this far (pixels) beyond the piece's box.
    radius_px : int
        The window is ``2 radius_px + 1`` pixels square.
    colour_scale : float
        A window pixel whose L*a*b* colour lies this far from the centre's weighs 1/2 in that
        image (``1 / (1 + distance^2 / colour_scale^2)``).
    min_weight_sum : float
        Windows whose weights (left times right) sum to less are not scored.
    min_score : float
        Least weighted NCC of a new match.
    min_margin : float
        A new match scores at least this much above the best score more than ``EXCLUSION_PX``
        whole disparities from it (a ramp or a repeat matches alike at many); a match with no
        such runner-up scored (a search cut short by the image's left border) is not confident.
    min_step_px, min_step_rel : float
        A strip's new matches lie at least ``max(min_step_px, min_step_rel * d)`` below the median
        disparity ``d`` of its piece: the strip lies clearly farther than the obstacle holding it.
    agree_px : float
        New matches within this of the strip's median new match agree; a piece's pixel whose new
        match lies within this of its disparity matches where it is.
    min_agreeing, min_agreeing_pixels : float, int
        Fraction of a strip's tested pixels with a confident match, and least number of them,
        whose matches must lie farther and agree for the strip to move.
    max_tested : int
        Pixels of a strip (spread over it) matched again to decide whether it moves; all its
        pixels are matched again only when it does.
    first_look_step, first_look_min : int
        A first look matches every ``first_look_step``-th tested pixel; the others are matched
        only when at least ``first_look_min`` of those score clearly (``min_score``,
        ``min_margin``) at ``max(min_step_px, min_step_rel * d)`` or more below ``d``. Over scenes
        0..959 this left out 81 % of the strips and none of those that move (``docs/pipeline.md``,
        session 41).
    """

    min_foreign_chroma: float = ColourSplitParameters.min_chroma_distance
    min_pixels: int = FringeParameters.min_pixels
    max_same_chroma: float = FringeParameters.max_same_chroma
    reach_px: int = 10
    radius_px: int = 4
    colour_scale: float = 5.0
    min_weight_sum: float = 8.0
    min_score: float = 0.5
    min_margin: float = 0.05
    min_step_px: float = 2.0
    min_step_rel: float = 0.15
    agree_px: float = 1.0
    min_agreeing: float = 0.5
    min_agreeing_pixels: int = 10
    max_tested: int = 40
    first_look_step: int = 3
    first_look_min: int = 2

    def __post_init__(self) -> None:
        check_numbers(self, (("min_foreign_chroma", 0.0, 400.0), ("max_same_chroma", 0.0, 400.0),
                             ("min_score", -1.0, 1.0), ("min_margin", 0.0, 2.0), ("min_step_px", 0.0, 1000.0),
                             ("min_step_rel", 0.0, 1.0), ("min_agreeing", 0.0, 1.0),
                             ("min_weight_sum", 0.0, 10.0 ** 6)))
        check_integers(self, (("min_pixels", 1, 10 ** 9), ("reach_px", 0, 10 ** 4), ("radius_px", 1, 50),
                              ("max_tested", 1, 10 ** 6), ("min_agreeing_pixels", 1, 10 ** 6),
                              ("first_look_step", 1, 10 ** 6), ("first_look_min", 0, 10 ** 6)))
        check_positive(self, ("colour_scale", "agree_px"))
        if self.first_look_min > self.min_agreeing_pixels:
            raise InvalidInputError(f"first_look_min ({self.first_look_min}) must not exceed min_agreeing_pixels "
                                    f"({self.min_agreeing_pixels}): the first look would refuse strips that move")


def compile_cover() -> None:
    """Compile the right camera's cover (:class:`_RightCover`), which a frame builds only for a
    strip that matches clearly farther (none in :func:`stereo_obstacles.pipeline.warm_up`'s pair)."""
    no_pixels = np.zeros(0, np.int64)
    _RightCover.of(np.zeros((1, 1), np.float32), np.zeros(1, np.int64), (no_pixels, no_pixels))


def own_colour_matches(obstacles: ObstacleList, chroma: np.ndarray, labels: np.ndarray, left: np.ndarray,
                       right: np.ndarray, disparity: np.ndarray, params: OwnColourParameters = OwnColourParameters()
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The strips of another colour in ``obstacles`` that match farther (module docstring).

    Parameters
    ----------
    obstacles
        The obstacles, whose ``id_map`` (``int (H, W)``) says which pixels each covers.
    chroma
        ``uint8 (H, W, 2)`` chroma of the left image (:attr:`stereo_obstacles.colour_split.ColourCue.chroma`).
    labels
        ``uint8 (H, W)`` phase-1 labels.
    left, right
        ``uint8 (H, W, 3)`` RGB pair.
    disparity
        ``float (H, W)`` left disparity in pixels, NaN where unmatched: the matches themselves,
        without the blind strip's extrapolation (pixels without a match are in no piece).
    params
        Which pieces, and when.

    Returns
    -------
    tuple
        ``taken_out`` (``bool (H, W)``): the obstacles' pixels of the strips that match farther
        (but those that match where they are);
        ``rematched`` (``bool (H, W)``): the strips' pixels whose new match agrees with their
        strip's; ``new_disparity`` (``float32 (H, W)``, pixels): those matches, NaN elsewhere.

    Raises
    ------
    InvalidInputError
        Inputs of other shapes than the id map's, or images that are not ``uint8``.
    """
    ids = np.asarray(obstacles.id_map)
    shape = ids.shape
    if (np.shape(chroma) != shape + (2,) or np.shape(labels) != shape or np.shape(disparity) != shape
            or np.shape(left) != shape + (3,) or np.shape(right) != shape + (3,)):
        raise InvalidInputError(f"chroma {np.shape(chroma)}, labels {np.shape(labels)}, disparity "
                                f"{np.shape(disparity)}, left {np.shape(left)} and right {np.shape(right)} must "
                                f"match the id map's (H, W) = {shape}")
    if np.asarray(left).dtype != np.uint8 or np.asarray(right).dtype != np.uint8:
        raise InvalidInputError(f"left and right must be uint8 RGB, got {np.asarray(left).dtype} and "
                                f"{np.asarray(right).dtype}")
    taken_out = np.zeros(shape, dtype=bool)
    rematched = np.zeros(shape, dtype=bool)
    new_disparity = np.full(shape, np.nan, dtype=np.float32)
    labels = np.asarray(labels)
    d = np.asarray(disparity, dtype=np.float32)
    pieces = _foreign_pieces(obstacles, ids, np.asarray(chroma), labels, d, params)
    if not pieces:
        return taken_out, rematched, new_disparity
    currents = [float(np.median(d[ys, xs])) for _, ys, xs in pieces]
    searches = [max(int(np.ceil(current)) + 1, 0) for current in currents]
    # converted once for all pieces: their strips, the strips' windows, their searches to the left
    images = _MatchingImages.around(left, right, [(ys, xs) for _, ys, xs in pieces], searches,
                                    params.reach_px + params.radius_px)
    for (obstacle, ys, xs), current, d_max in zip(pieces, currents, searches):
        below = current - max(params.min_step_px, params.min_step_rel * current)
        sy, sx = _strip(images, labels, ids, obstacle.id, ys, xs, params)
        tested = np.unique(np.linspace(0, len(sy) - 1, min(params.max_tested, len(sy))).astype(np.int64))
        looked = _first_look_then_all(images, sy[tested], sx[tested], d_max, below, params)
        if looked is None:
            continue
        new, scored = looked
        if np.count_nonzero(_farther(new, scored, below)) < params.min_agreeing_pixels:
            continue        # too few to agree farther, whatever the right camera sees (its cover costs)
        cover = _RightCover.of(d, sy, (ys, xs))         # the strip's rows, for its tested pixels and all
        centre = _farther_centre(new, scored & cover.sees(sy[tested], sx[tested], new), below, params)
        if centre is None:
            continue
        of_obstacle = ids[sy, sx] == obstacle.id
        new, scored = _own_matches(images, sy, sx, d_max, params)
        confident = scored & cover.sees(sy, sx, new)
        agree = _farther(new, confident, below) & (np.abs(new - centre) <= params.agree_px)
        rematched[sy[agree], sx[agree]] = True
        new_disparity[sy[agree], sx[agree]] = new[agree]
        # the strip's pixels leave the obstacle, but those that match confidently where they are
        leaving = of_obstacle & ~(confident & (np.abs(new - d[sy, sx]) <= params.agree_px))
        taken_out[sy[leaving], sx[leaving]] = True
    return taken_out, rematched, new_disparity


def _strip(images: _MatchingImages, labels: np.ndarray, ids: np.ndarray, obstacle_id: int, ys: np.ndarray,
           xs: np.ndarray, params: OwnColourParameters) -> tuple[np.ndarray, np.ndarray]:
    """Rows and columns (``int64 (n,)``) of the piece ``(ys, xs)`` of obstacle ``obstacle_id`` and
    of the pixels connected to it (8 neighbours) within ``reach_px`` of its box that phase 1
    calls obstacle, lie in no other obstacle, and whose ``(a*, b*)`` (of ``images``, which hold
    that box) lies within ``max_same_chroma`` of the piece's median: the whole strip of its
    colour, its unmatched pixels too."""
    h, w = ids.shape
    y0, x0 = max(int(ys.min()) - params.reach_px, 0), max(int(xs.min()) - params.reach_px, 0)
    y1, x1 = min(int(ys.max()) + params.reach_px + 1, h), min(int(xs.max()) + params.reach_px + 1, w)
    lab_left = images.lab_left[y0 - images.top:y1 - images.top, x0 - images.left:x1 - images.left]
    colour = np.median(lab_left[ys - y0, xs - x0, 1:], axis=0)
    window_ids = ids[y0:y1, x0:x1]
    same = ~chroma_apart(lab_left[..., 1:].reshape(-1, 2), colour, params.max_same_chroma)
    same = same.reshape(window_ids.shape) & (labels[y0:y1, x0:x1] == Label.OBSTACLE.value)
    same &= (window_ids == 0) | (window_ids == obstacle_id)
    same[ys - y0, xs - x0] = True
    _, piece_of = cv2.connectedComponents(same.astype(np.uint8), connectivity=8)
    sy, sx = np.nonzero(piece_of == piece_of[ys[0] - y0, xs[0] - x0])
    return sy.astype(np.int64) + y0, sx.astype(np.int64) + x0


@dataclass(frozen=True)
class _MatchingImages:
    """Part of the pair as the kernel reads it: L*a*b* (``float32 (h, w, 3)``) and grey (``float32
    (h, w)``) of the rows and columns from ``(top, left)`` on."""

    top: int
    left: int
    lab_left: np.ndarray
    lab_right: np.ndarray
    grey_left: np.ndarray
    grey_right: np.ndarray

    @classmethod
    def around(cls, left: np.ndarray, right: np.ndarray, pieces: list[tuple[np.ndarray, np.ndarray]],
               searches: list[int], margin: int) -> _MatchingImages:
        """The box of the ``uint8 (H, W, 3)`` RGB pair that holds every piece's rows and columns
        (``pieces``) with ``margin`` pixels around, and ``searches`` (whole disparities, one a
        piece) more to its left."""
        def lab(image):
            return cv2.cvtColor(image.astype(np.float32) / 255.0, cv2.COLOR_RGB2Lab)

        def grey(image):
            return cv2.cvtColor(image, cv2.COLOR_RGB2GRAY).astype(np.float32)

        h, w = left.shape[:2]
        top = max(min(int(ys.min()) for ys, _ in pieces) - margin, 0)
        bottom = min(max(int(ys.max()) for ys, _ in pieces) + margin + 1, h)
        first = max(min(int(xs.min()) - search for (_, xs), search in zip(pieces, searches)) - margin, 0)
        last = min(max(int(xs.max()) for _, xs in pieces) + margin + 1, w)
        left, right = (np.ascontiguousarray(image[top:bottom, first:last]) for image in (left, right))
        return cls(top, first, lab(left), lab(right), grey(left), grey(right))


def _foreign_pieces(obstacles: ObstacleList, ids: np.ndarray, chroma: np.ndarray, labels: np.ndarray,
                    disparity: np.ndarray, params: OwnColourParameters
                    ) -> list[tuple[Obstacle, np.ndarray, np.ndarray]]:
    """Each obstacle with the rows and columns (``int64 (n,)``) of each connected piece (8
    neighbours) of at least ``min_pixels`` of its pixels that phase 1 calls obstacle, that have a
    disparity (``float (H, W)``: not the blind strip's extrapolation) and whose chroma lies at least
    ``min_foreign_chroma`` from the obstacle's median chroma."""
    pieces = []
    for obstacle in obstacles.obstacles:
        ys, xs = obstacle_pixels(obstacle, ids)
        if len(ys) < params.min_pixels:
            continue
        own = chroma[ys, xs].astype(np.int32)
        foreign = chroma_apart(own, np.median(own, axis=0), params.min_foreign_chroma)
        foreign &= (labels[ys, xs] == Label.OBSTACLE.value) & np.isfinite(disparity[ys, xs])
        if np.count_nonzero(foreign) < params.min_pixels:
            continue
        x0, y0, x1, y1 = obstacle.box_px
        mask = np.zeros((y1 - y0, x1 - x0), dtype=np.uint8)
        mask[ys[foreign] - y0, xs[foreign] - x0] = 1
        _, piece_of, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
        for piece in np.flatnonzero(stats[1:, cv2.CC_STAT_AREA] >= params.min_pixels) + 1:
            first, top, width, height = stats[piece, [cv2.CC_STAT_LEFT, cv2.CC_STAT_TOP, cv2.CC_STAT_WIDTH,
                                                      cv2.CC_STAT_HEIGHT]]
            py, px = np.nonzero(piece_of[top:top + height, first:first + width] == piece)
            pieces.append((obstacle, py.astype(np.int64) + top + y0, px.astype(np.int64) + first + x0))
    return pieces


def _own_matches(images: _MatchingImages, ys: np.ndarray, xs: np.ndarray, d_max: int, params: OwnColourParameters
                 ) -> tuple[np.ndarray, np.ndarray]:
    """The own-colour matches of the pixels ``(ys, xs)`` searched from 0 to ``d_max``
    (``float32 (n,)``, pixels) and whether each scores clearly (``bool (n,)``: ``min_score`` or
    more, ``min_margin`` above its runner-up). A match is confident when it scores clearly and
    the right camera sees it there (:class:`_RightCover`): a pixel left of a nearer object is
    hidden from the right camera, and whatever it matches there is not itself."""
    new, score, runner_up = own_colour_best_kernel(
        images.lab_left, images.lab_right, images.grey_left, images.grey_right, ys - images.top, xs - images.left,
        np.full(len(ys), d_max, np.int64), params.radius_px, params.colour_scale, params.min_weight_sum,
        EXCLUSION_PX)
    return new, (score >= params.min_score) & (score - runner_up >= params.min_margin)


def _first_look_then_all(images: _MatchingImages, ys: np.ndarray, xs: np.ndarray, d_max: int, below: float,
                         params: OwnColourParameters) -> tuple[np.ndarray, np.ndarray] | None:
    """:func:`_own_matches` of the tested pixels ``(ys, xs)``, or ``None`` when fewer than
    ``first_look_min`` of every ``first_look_step``-th of them score clearly at ``below`` or lower
    (the others are then not matched)."""
    first = np.zeros(len(ys), dtype=bool)
    first[::params.first_look_step] = True
    new = np.empty(len(ys), dtype=np.float32)
    scored = np.empty(len(ys), dtype=bool)
    new[first], scored[first] = _own_matches(images, ys[first], xs[first], d_max, params)
    if np.count_nonzero(_farther(new[first], scored[first], below)) < params.first_look_min:
        return None
    new[~first], scored[~first] = _own_matches(images, ys[~first], xs[~first], d_max, params)
    return new, scored


@dataclass(frozen=True)
class _RightCover:
    """The nearest disparity the right camera sees at each column of some rows, from the matches
    of a disparity map without a piece's own (its fattened matches would hide it from itself):
    :func:`stereo_obstacles._own_colour_kernel.right_cover_rows_kernel` with the visibility
    test's defaults. ``row_index`` (``int64 (H,)``) gives each image row's row in ``nearest``."""

    row_index: np.ndarray
    nearest: np.ndarray

    @classmethod
    def of(cls, disparity: np.ndarray, rows: np.ndarray, without: tuple[np.ndarray, np.ndarray]) -> _RightCover:
        """Over the image ``rows`` (``int (n,)``, repeats allowed) of ``disparity`` (``float32 (H,
        W)``), without the pixels ``without`` (rows and columns)."""
        wanted = np.unique(rows)
        row_index = np.full(disparity.shape[0], -1, np.int64)
        row_index[wanted] = np.arange(len(wanted))
        band = disparity[wanted]
        kept = row_index[without[0]] >= 0
        band[row_index[without[0][kept]], without[1][kept]] = np.nan
        params = VisibilityParameters()
        return cls(row_index, right_cover_rows_kernel(band, params.max_gap_px, params.surface_tolerance_px))

    def sees(self, ys: np.ndarray, xs: np.ndarray, d: np.ndarray) -> np.ndarray:
        """``bool (n,)``: whether the right camera sees the left pixels ``(ys, xs)`` at disparities
        ``d`` (no surface more than the visibility test's ``min_depth_gap_px`` nearer covers
        their right-image column); False where ``d`` is NaN.

        Raises
        ------
        ValueError
            A row the cover was not made for.
        """
        if (self.row_index[ys] < 0).any():
            raise ValueError("the cover was not made for all these rows")
        with np.errstate(invalid="ignore"):
            columns = np.floor(xs - d + 0.5)
        inside = np.isfinite(columns) & (columns >= 0) & (columns < self.nearest.shape[1])
        seen = np.zeros(len(ys), dtype=bool)
        nearest = self.nearest[self.row_index[ys[inside]], columns[inside].astype(np.int64)]
        seen[inside] = ~(nearest > d[inside] + VisibilityParameters().min_depth_gap_px)
        return seen


def _farther(new: np.ndarray, kept: np.ndarray, below: float) -> np.ndarray:
    """``bool (n,)``: the matches ``new`` (``float32 (n,)``, pixels) that are ``kept`` (``bool
    (n,)``) and lie at ``below`` or lower."""
    return kept & (new <= below)


def _farther_centre(new: np.ndarray, confident: np.ndarray, below: float, params: OwnColourParameters) -> float | None:
    """The disparity the confident matches ``new`` (``float32 (n,)``, ``bool (n,)``) agree on at
    ``below`` or lower (their median), or ``None`` when fewer than ``min_agreeing`` of the confident
    matches, or fewer than ``min_agreeing_pixels``, lie there within ``agree_px`` of it (the pixels
    of the obstacle's own surface that a strip holds match confidently where they are)."""
    farther = _farther(new, confident, below)
    needed = max(params.min_agreeing * np.count_nonzero(confident), params.min_agreeing_pixels)
    if np.count_nonzero(farther) < needed:
        return None
    centre = float(np.median(new[farther]))
    return centre if np.count_nonzero(farther & (np.abs(new - centre) <= params.agree_px)) >= needed else None


def moved_groups(moved: np.ndarray, disparity: np.ndarray, first_number: int,
                 params: GroupingParameters = GroupingParameters()) -> np.ndarray:
    """``int32 (H, W)``: the connected pieces (8 neighbours) of the ``moved`` pixels (``bool (H,
    W)``) that hold an object's pixel count by the grouping's rule (far ones fewer:
    :func:`stereo_obstacles.obstacle_grouping.object_sized`, with ``disparity`` in pixels),
    numbered from ``first_number``; 0 elsewhere."""
    count, piece_of = cv2.connectedComponents(np.asarray(moved, dtype=np.uint8), connectivity=8)
    pieces = piece_of.astype(np.int64) - 1
    sized = object_sized(pieces, np.nan_to_num(np.asarray(disparity, dtype=np.float64)),
                         np.bincount(pieces[pieces >= 0], minlength=count - 1), params)
    numbers = np.zeros(count, dtype=np.int32)
    numbers[1:][sized] = first_number + np.arange(np.count_nonzero(sized), dtype=np.int32)
    return numbers[piece_of]
