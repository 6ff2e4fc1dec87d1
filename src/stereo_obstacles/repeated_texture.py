"""Islands of matches that took a repeat of the texture around them.

A wall, a fence or paving whose texture repeats every ``p`` pixels along a row matches at its
true disparity ``d`` and about as well at ``d + p``: one period further along, the right image
shows the same texture. Where the scanline search or the growth takes the repeat, a patch of the
surface is matched ``p`` pixels too far and stands out as a surface floating in front of it. In
scenes 589 and 1470, concrete walls at 2.94 and 3.11 m (detail texture repeating every 1.02 m,
about 180 px at that depth) carried patches matched at 200-202 px instead of 21: obstacles at
0.33 m, and the visibility test, trusting the nearer surface, removed correct wall matches beside
them (``docs/pipeline.md``, session 39).

An *island* is a region of matched pixels (:func:`stereo_obstacles.speckles.disparity_regions`,
neighbours within ``max_step_px``) of ``min_pixels`` at least, and at most ``max_image_fraction``
of the image (the ground and what stands on it form one large region), whose median disparity
exceeds by
``min_jump_px`` at least the *surrounding disparity*: the median disparity of the other regions'
matched pixels within ``ring_px`` of it (``min_ring_pixels`` of them at least). A pixel of an
island *repeats* when

* it matches well at the surrounding disparity: its best NCC within ``search_px`` of it reaches
  ``min_similarity``;
* and not between the two: the median of its NCC at ``between_samples`` whole disparities
  spread evenly between the two (outside ``search_px`` of both; windows too flat to score, or
  right pixels outside the image, left out) is below ``max_between_similarity``.

NCC as the matcher scores it on 5 x 5 windows, with the default ``min_std`` of
:func:`~stereo_obstacles.similarity.prepare_similarity`; ``ring_px`` bounds both the ring (pixels
within ``ring_px`` rows and columns of the island) and the first look below.

Only the regions whose facing matches (the next match of another region along each row and
column, within ``ring_px``) lie on average ``min_jump_px`` or more below them have their ring
gathered: a cheap first look, in the pass that measures the regions' sizes and boxes.

An island whose pixels repeat (``min_repeating_fraction`` of them, judged on at most
``max_tested_pixels`` spread over it) is removed. A real object in front of a surface shows
nothing of its own texture at the surface's disparity, where the right image holds whatever lies
beside it. A horizontal edge (the top of a wall against the ground behind it) matches at every
disparity of its row, the surface's and those between alike: it is not a repeat (scene 43: the
top of a wall at 24 px before the ground at 8 px, similarity 0.88-0.99 at 8 px and a median of
0.92-0.99 between).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from stereo_obstacles._repeated_texture_kernel import region_stats_kernel
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import check_integers, check_numbers
from stereo_obstacles.image_pairs import check_same_size
from stereo_obstacles.similarity import (RADIUS, UNDEFINED, SimilarityInputs, grey_pair, prepare_similarity,
                                         similarity_at)
from stereo_obstacles.speckles import disparity_regions

__all__ = ["RepeatedTextureParameters", "repeat_islands"]


@dataclass(frozen=True)
class RepeatedTextureParameters:
    """When an island of matches took a repeat of the texture around it (module docstring).
    Disparities in pixels of the images given to :func:`repeat_islands`.

    Attributes
    ----------
    max_step_px : float
        Neighbouring matches within this of each other are in one region.
    min_pixels : int
        Smaller regions are not tested.
    max_image_fraction : float
        Nor are regions of more than this fraction of the image's pixels.
    min_jump_px : float
        An island stands at least this far in front of the surrounding disparity.
    ring_px : int
        The ring around an island whose matches give the surrounding disparity: the pixels
        within this many rows and columns of it; also how far the first look reaches.
    min_ring_pixels : int
        Matches the ring needs to give it.
    search_px : int
        The similarity at the surrounding disparity is the best within this of it.
    min_similarity : float
        Similarity a repeating pixel reaches at the surrounding disparity.
    between_samples : int
        Disparities between the two at which a pixel is scored.
    max_between_similarity : float
        A repeating pixel's median similarity there stays below this.
    min_repeating_fraction : float
        Fraction of an island's tested pixels that must repeat.
    max_tested_pixels : int
        At most this many of an island's pixels, spread over it, are tested.
    """

    max_step_px: float = 1.0
    min_pixels: int = 10
    max_image_fraction: float = 0.05
    min_jump_px: float = 8.0
    ring_px: int = 5
    min_ring_pixels: int = 10
    search_px: int = 2
    min_similarity: float = 0.8
    between_samples: int = 8
    max_between_similarity: float = 0.5
    min_repeating_fraction: float = 0.5
    max_tested_pixels: int = 400

    def __post_init__(self) -> None:
        check_integers(self, (("min_pixels", 1, 10 ** 9), ("ring_px", 1, 1000), ("min_ring_pixels", 1, 10 ** 9),
                              ("search_px", 0, 1000), ("between_samples", 1, 1000),
                              ("max_tested_pixels", 1, 10 ** 9)))
        check_numbers(self, (("max_step_px", 0.0, 1000.0), ("min_jump_px", 2 * self.search_px + 2, 10 ** 6),
                             ("min_similarity", -1.0, 1.0), ("max_between_similarity", -1.0, 1.0),
                             ("min_repeating_fraction", 0.0, 1.0), ("max_image_fraction", 0.0, 1.0)))


def repeat_islands(disparity: np.ndarray, left: np.ndarray, right: np.ndarray,
                   params: RepeatedTextureParameters = RepeatedTextureParameters()) -> np.ndarray:
    """``bool (H, W)``: the matches of the islands that took a repeat of the texture around them
    (module docstring).

    Parameters
    ----------
    disparity
        ``float (H, W)`` left disparity in pixels, NaN where unmatched (read as float32).
    left, right
        The rectified pair ``disparity`` was matched on, ``(H, W, 3)`` RGB or ``(H, W)`` grey;
        converted to grey (:func:`stereo_obstacles.similarity.grey_pair`) only when an island
        stands in front of its surroundings, and scored on the rows of each such island.
    params
        The thresholds.

    Examples
    --------
    A wall whose texture repeats every 24 columns, matched at 6 px but for a patch matched one
    period further, at 30 px:

    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> period = rng.uniform(0, 255, (60, 24)).astype(np.float32)
    >>> right = np.tile(period, (1, 5))                      # 60 x 120
    >>> left = np.roll(right, 6, axis=1)                     # the wall at 6 px everywhere
    >>> disparity = np.full(right.shape, 6.0, np.float32)
    >>> disparity[20:30, 60:75] = 30.0
    >>> found = repeat_islands(disparity, left, right)
    >>> bool(found[20:30, 60:75].all()), int(found.sum())
    (True, 150)
    """
    check_same_size(left, right)
    labels, count = disparity_regions(disparity, max_difference_px=params.max_step_px)   # checks the map
    if labels.shape != np.shape(left)[:2]:
        raise InvalidInputError(f"disparity: expected the images' shape {np.shape(left)[:2]}, got {labels.shape}")
    disparity = np.ascontiguousarray(disparity, np.float32)
    removed = np.zeros(disparity.shape, np.bool_)
    if count == 0:
        return removed
    sizes, boxes, mean_step = region_stats_kernel(labels, disparity, count, params.ring_px)
    greys = None
    tested_sizes = (sizes >= params.min_pixels) & (sizes <= params.max_image_fraction * disparity.size)
    # the matches a region faces across its border stand, on average, below it: a cheap first
    # look, before its ring is gathered
    for region in np.flatnonzero(tested_sizes & (mean_step >= params.min_jump_px)):
        ys, xs, surrounding = _island(labels, disparity, region, boxes[region], params)
        own = float(np.median(disparity[ys, xs]))
        if surrounding is None or own - surrounding < params.min_jump_px:
            continue
        if greys is None:
            greys = grey_pair(left, right)
        tested = np.linspace(0, ys.size - 1, min(ys.size, params.max_tested_pixels)).astype(np.int64)
        repeats = _repeating(greys, ys[tested], xs[tested], own, surrounding, params)
        if np.mean(repeats) >= params.min_repeating_fraction:
            removed[ys, xs] = True
    return removed


def _island(labels: np.ndarray, disparity: np.ndarray, region: int, box: np.ndarray,
            params: RepeatedTextureParameters) -> tuple[np.ndarray, np.ndarray, float | None]:
    """The pixels of ``region`` (rows and columns, ``int64 (n,)``) and its surrounding disparity
    (``None`` with fewer than ``min_ring_pixels`` matches in the ring)."""
    h, w = labels.shape
    ring = params.ring_px
    y0, x0 = max(int(box[0]) - ring, 0), max(int(box[1]) - ring, 0)
    y1, x1 = min(int(box[2]) + ring, h), min(int(box[3]) + ring, w)
    inside = (labels[y0:y1, x0:x1] == region).view(np.uint8)
    around = cv2.dilate(inside, np.ones((2 * ring + 1, 2 * ring + 1), np.uint8)).view(np.bool_)
    around &= (labels[y0:y1, x0:x1] >= 0) & (inside == 0)
    ys, xs = np.nonzero(inside)
    ring_disparity = disparity[y0:y1, x0:x1][around]
    surrounding = float(np.median(ring_disparity)) if ring_disparity.size >= params.min_ring_pixels else None
    return ys + y0, xs + x0, surrounding


def _repeating(greys: tuple[np.ndarray, np.ndarray], ys: np.ndarray, xs: np.ndarray, own: float,
               surrounding: float, params: RepeatedTextureParameters) -> np.ndarray:
    """``bool (n,)``: which of the pixels ``(ys, xs)`` of an island at disparity ``own`` repeat
    at the ``surrounding`` disparity (module docstring), on the grey pair ``greys``."""
    # the window statistics of the island's rows only, as SimilarityInputs.rows keeps them
    top, bottom = max(int(ys.min()) - RADIUS, 0), min(int(ys.max()) + RADIUS + 1, greys[0].shape[0])
    inputs = prepare_similarity(greys[0][top:bottom], greys[1][top:bottom])
    ys = ys - top
    centre = int(round(surrounding))
    around = np.arange(centre - params.search_px, centre + params.search_px + 1)
    between = np.rint(np.linspace(centre + params.search_px + 1, round(own) - params.search_px - 1,
                                  params.between_samples)).astype(np.int64)
    similarities = _similarity_at_disparities(inputs, ys, xs, np.concatenate([around, between]))
    at_surrounding = similarities[:around.size].max(axis=0)
    scored = np.ma.masked_equal(similarities[around.size:], UNDEFINED)
    in_between = np.ma.median(scored, axis=0).filled(np.inf)          # nothing scored: no evidence
    return (at_surrounding >= params.min_similarity) & (in_between < params.max_between_similarity)


def _similarity_at_disparities(inputs: SimilarityInputs, ys: np.ndarray, xs: np.ndarray,
                               disparities: np.ndarray) -> np.ndarray:
    """``float32 (k, n)``: similarity of the left pixels ``(ys, xs)`` (``int64 (n,)``) at each of
    the ``k`` integer ``disparities``; :data:`~stereo_obstacles.similarity.UNDEFINED` where the
    right pixel lies outside the image."""
    x_right = xs[None, :] - disparities[:, None]
    inside = (x_right >= 0) & (x_right < inputs.shape[1])
    out = np.full(x_right.shape, UNDEFINED, np.float32)
    rows, columns = (np.broadcast_to(v[None, :], x_right.shape)[inside] for v in (ys, xs))
    out[inside] = similarity_at(inputs, rows, columns, x_right[inside])
    return out
