"""An obstacle's fringe coloured like a farther obstacle beside it: the matching's fattening.

Beside a step in depth, the 5 x 5 window of a match is dominated by the more textured side, and
the nearer object's disparity spreads over the edge of a farther, textureless one. Those pixels
are grouped with the nearer object: a box at 5.1 m beside a cylinder at 3.9 m had 245 of its
pixels matched at the cylinder's edge disparities (14.5-15.75 px against its own 12.8) and
grouped with the cylinder, while the rest of its edge formed an obstacle of its own
(``docs/pipeline.md``, session 37). The matching does not spread colour. So the pixels of an
obstacle

- whose chroma lies at least ``min_foreign_chroma`` from the obstacle's median chroma,
- and less than ``max_same_chroma`` from the median chroma of a farther obstacle (its median
  disparity at least ``min_step_rel`` smaller: a step in disparity, which with a large ``doffs``
  is a smaller step in depth) that lies within ``band_px`` of them,
- in a connected piece of at least ``min_pixels``,

are that farther object's edge, and are taken out of the nearer obstacle. They are not given to
the farther one: their disparities are the nearer one's and would pull its distance near.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import cv2
import numpy as np

from stereo_obstacles.colour_split import ColourSplitParameters, chroma_apart
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import check_integers, check_numbers
from stereo_obstacles.obstacle_grouping import GroupingParameters
from stereo_obstacles.obstacles import Obstacle, ObstacleList, obstacle_pixels

__all__ = ["FringeParameters", "fattened_fringes"]


@dataclass(frozen=True)
class FringeParameters:
    """Which pixels of an obstacle are a farther obstacle's fattened edge (module docstring).

    Attributes
    ----------
    min_foreign_chroma : float
        Least distance in ``(a*, b*)`` (CIE L*a*b* units) of such a pixel's chroma from its own
        obstacle's median chroma: twice the colour split's ``min_chroma_distance``.
    max_same_chroma : float
        Its chroma lies less than this from the farther obstacle's median chroma, in ``(a*, b*)``:
        the colour split's ``min_chroma_distance``, below which two colours are one.
    band_px : int
        Greatest distance (pixels) of such a pixel from the farther obstacle.
    min_step_rel : float
        The farther obstacle's median disparity lies at least this fraction below the nearer one's
        (0: no more than it).
    min_pixels : int
        Least size (pixels) of a connected piece of such pixels: a quarter of the grouping's
        ``min_object_pixels``.
    """

    min_foreign_chroma: float = 2 * ColourSplitParameters.min_chroma_distance
    max_same_chroma: float = ColourSplitParameters.min_chroma_distance
    band_px: int = 8
    min_step_rel: float = 0.03
    min_pixels: int = GroupingParameters.min_object_pixels // 4

    def __post_init__(self) -> None:
        check_numbers(self, (("min_foreign_chroma", 0.0, 400.0), ("max_same_chroma", 0.0, 400.0),
                             ("min_step_rel", 0.0, 1.0)))
        check_integers(self, (("band_px", 1, 10 ** 4), ("min_pixels", 1, 10 ** 9)))


def fattened_fringes(obstacles: ObstacleList, chroma: np.ndarray,
                     params: FringeParameters = FringeParameters()) -> np.ndarray:
    """``bool (H, W)``: the pixels of ``obstacles`` that are a farther obstacle's fattened edge
    (module docstring).

    Parameters
    ----------
    obstacles
        The obstacles, whose ``id_map`` (``int (H, W)``, 0: none) says which pixels each covers.
    chroma
        ``uint8 (H, W, 2)`` chroma of the left image
        (:attr:`stereo_obstacles.colour_split.ColourCue.chroma`).
    params
        Which pixels.

    Raises
    ------
    InvalidInputError
        ``chroma`` not ``uint8 (H, W, 2)`` of the id map's height and width.

    Examples
    --------
    A brown strip 6 px wide grouped with a blue box, beside a brown wall farther away:

    >>> from stereo_obstacles.obstacles import Obstacle, ObstacleList
    >>> ids = np.zeros((40, 60), np.int32); ids[:, :30] = 1; ids[:, 30:] = 2
    >>> chroma = np.full((40, 60, 2), 150, np.uint8); chroma[:, :24] = (128, 100)
    >>> boxes = [Obstacle(1, (0, 0, 30, 40), 1200, 12.0, 1.0), Obstacle(2, (30, 0, 60, 40), 1200, 8.0, 1.0)]
    >>> fringe = fattened_fringes(ObstacleList(obstacles=tuple(boxes), id_map=ids), chroma)
    >>> [int(column) for column in np.flatnonzero(fringe.any(axis=0))]
    [24, 25, 26, 27, 28, 29]
    """
    ids = np.asarray(obstacles.id_map)
    chroma = np.asarray(chroma)
    if chroma.shape != ids.shape + (2,) or chroma.dtype != np.uint8:
        raise InvalidInputError(f"chroma ({chroma.dtype} {chroma.shape}) must be uint8 (H, W, 2) for the id map's "
                                f"(H, W) = {ids.shape}")
    pixels: dict[int, _Pixels] = {}                  # each obstacle's, taken when first needed

    def pixels_of(obstacle: Obstacle) -> _Pixels:
        if obstacle.id not in pixels:
            pixels[obstacle.id] = _Pixels.of(obstacle, ids, chroma)
        return pixels[obstacle.id]

    fringe = np.zeros(ids.shape, dtype=bool)
    for nearer in obstacles.obstacles:
        neighbours = [farther for farther in obstacles.obstacles
                      if farther.id != nearer.id
                      and farther.disparity_px <= (1 - params.min_step_rel) * nearer.disparity_px
                      and _boxes_within(nearer.box_px, farther.box_px, params.band_px)
                      and len(pixels_of(farther).ys) > 0]
        if not neighbours:
            continue
        own = pixels_of(nearer)
        if len(own.ys) < params.min_pixels:
            continue
        foreign = own.where(chroma_apart(own.chroma, own.colour, params.min_foreign_chroma))
        if len(foreign.ys) < params.min_pixels:
            continue
        for farther in neighbours:
            # pixels of the farther obstacle's colour first: most pairs have too few to look further
            candidates = foreign.where(~chroma_apart(foreign.chroma, pixels_of(farther).colour, params.max_same_chroma))
            if len(candidates.ys) >= params.min_pixels:
                x0, y0, x1, y1 = nearer.box_px
                fringe[y0:y1, x0:x1] |= _edge_of(farther, ids, candidates, nearer.box_px, params)
    return fringe


@dataclass(frozen=True)
class _Pixels:
    """Some pixels of an obstacle: rows and columns (``int64 (n,)``) and chroma (``int32 (n, 2)``)."""

    ys: np.ndarray
    xs: np.ndarray
    chroma: np.ndarray

    @cached_property
    def colour(self) -> np.ndarray:
        """``float64 (2,)``: their median chroma."""
        return np.median(self.chroma, axis=0)

    @classmethod
    def of(cls, obstacle: Obstacle, ids: np.ndarray, chroma: np.ndarray) -> _Pixels:
        """All the obstacle's pixels."""
        ys, xs = obstacle_pixels(obstacle, ids)
        return cls(ys, xs, chroma[ys, xs].astype(np.int32))

    def where(self, chosen: np.ndarray) -> _Pixels:
        """The pixels where ``chosen`` (``bool (n,)``) holds."""
        return _Pixels(self.ys[chosen], self.xs[chosen], self.chroma[chosen])


def _edge_of(farther: Obstacle, ids: np.ndarray, candidates: _Pixels, box: tuple[int, int, int, int],
             params: FringeParameters) -> np.ndarray:
    """``bool`` over ``box`` (the nearer obstacle's, ``(x0, y0, x1, y1)``): the pieces of at least
    ``min_pixels`` of the ``candidates`` (pixels of the nearer obstacle of the farther one's
    colour) that lie within ``band_px`` of ``farther``."""
    x0, y0, x1, y1 = box
    band = params.band_px
    # the distances to the farther obstacle over the box widened by the band (beyond it they exceed it)
    wx0, wy0 = max(x0 - band, 0), max(y0 - band, 0)
    wx1, wy1 = min(x1 + band, ids.shape[1]), min(y1 + band, ids.shape[0])
    apart = (ids[wy0:wy1, wx0:wx1] != farther.id).astype(np.uint8)
    distance = cv2.distanceTransform(apart, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    within = distance[candidates.ys - wy0, candidates.xs - wx0] <= band
    edge = np.zeros((y1 - y0, x1 - x0), dtype=np.uint8)
    if np.count_nonzero(within) < params.min_pixels:
        return edge.astype(bool)
    edge[candidates.ys[within] - y0, candidates.xs[within] - x0] = 1
    _, pieces, stats, _ = cv2.connectedComponentsWithStats(edge, connectivity=8)
    large = stats[:, cv2.CC_STAT_AREA] >= params.min_pixels
    large[0] = False
    return large[pieces]


def _boxes_within(first: tuple[int, int, int, int], second: tuple[int, int, int, int], gap_px: int) -> bool:
    """Whether two boxes ``(x0, y0, x1, y1)`` lie no more than ``gap_px`` apart (or overlap)."""
    return (first[0] - gap_px < second[2] and second[0] - gap_px < first[2]
            and first[1] - gap_px < second[3] and second[1] - gap_px < first[3])
