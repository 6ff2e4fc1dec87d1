"""Whether the background shows between two obstacles side by side in the image.

The pieces of one object can stand apart in the image: a pole above and below a nearer box, the
two outlines of a textureless face. What lies between them is then a nearer object, or the
object itself left unmatched. Two objects side by side show what stands behind them in between:
two cyan poles 0.5 m apart in depth, each leaning in the image, had footprints on the ground
plan that met end to end (the near pole's foot beside the far pole's top), though the wall and
the ground behind them were matched in the 20 columns between them (``docs/pipeline.md``,
session 38).

In each row where one obstacle lies wholly left of the other, the matched pixels between them
*show the background* when at least ``min_row_fraction`` of them (and ``min_row_matched`` at
least) lie more than ``gap_m`` behind the farther of the two obstacles' pixels that face each
other across the row, and look unlike both obstacles: their chroma lies at least
``min_chroma_distance`` from both obstacles' median chroma, or, when phase 1 calls most pixels
of both obstacles obstacle, phase 1 does not call them obstacle (grey ground between two grey
objects). The colour condition keeps the stray matches of a textureless face, which carry the
background's disparity but the face's colour, from parting its outlines. The background shows
between the two when it does in at least ``min_rows`` of those rows, and in at least
``min_rows_fraction`` of them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.colour_split import ColourCue, chroma_apart
from stereo_obstacles.depth import disparity_to_depth
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import check_integers, check_numbers

__all__ = ["SeenThroughParameters", "background_between"]


@dataclass(frozen=True)
class SeenThroughParameters:
    """How many rows must show the background between two obstacles (module docstring).

    Attributes
    ----------
    min_row_matched : int
        Matched pixels a row needs between the two to say anything.
    min_row_fraction : float
        Fraction of a row's matched pixels between the two that must show the background.
    min_rows : int
        Rows that must show it.
    min_rows_fraction : float
        Fraction of the rows where the two lie side by side that must show it.
    """

    min_row_matched: int = 2
    min_row_fraction: float = 0.5
    min_rows: int = 5
    min_rows_fraction: float = 0.25

    def __post_init__(self) -> None:
        check_integers(self, (("min_row_matched", 1, 10 ** 6), ("min_rows", 1, 10 ** 6)))
        check_numbers(self, (("min_row_fraction", 0.0, 1.0), ("min_rows_fraction", 0.0, 1.0)))


def background_between(first: tuple[np.ndarray, np.ndarray], second: tuple[np.ndarray, np.ndarray],
                       disparity: np.ndarray, cue: ColourCue, median_chroma: tuple[np.ndarray, np.ndarray],
                       calibration: StereoCalibration, gap_m: float, min_chroma_distance: float,
                       params: SeenThroughParameters = SeenThroughParameters()) -> bool:
    """Whether the background shows between two obstacles (module docstring).

    Parameters
    ----------
    first, second
        Each obstacle's pixels: rows and columns (``int64 (n,)``, ``n >= 1``), none shared.
    disparity
        ``float32 (H, W)``, pixels, NaN where unmatched (the disparity the obstacles were
        measured on, finite at their pixels).
    cue
        The left image's chroma and phase-1 colour verdict, ``(H, W)`` as ``disparity``.
    median_chroma
        Each obstacle's median chroma (``(2,)``, as :attr:`ColourCue.chroma`).
    calibration
        The rig, for depths in metres.
    gap_m
        Depth (metres) by which a pixel must lie behind the two.
    min_chroma_distance
        Its chroma must lie this far from both obstacles' (``(a*, b*)`` units).
    params
        How many rows must show it.

    Returns
    -------
    bool
        False as well when the two share fewer than ``min_rows`` rows side by side.

    Raises
    ------
    InvalidInputError
        An obstacle without pixels, or ``disparity`` and ``cue`` of other heights and widths.
    """
    (ys_a, xs_a), (ys_b, xs_b) = first, second
    if min(len(ys_a), len(ys_b)) == 0:
        raise InvalidInputError("each obstacle needs at least one pixel")
    if np.ndim(disparity) != 2 or cue.chroma.shape[:2] != np.shape(disparity):
        raise InvalidInputError(f"disparity {np.shape(disparity)} and chroma {cue.chroma.shape} must be (H, W) and "
                                f"(H, W, 2)")
    y0, y1 = max(ys_a.min(), ys_b.min()), min(ys_a.max(), ys_b.max()) + 1
    if y0 >= y1:
        return False
    lo_a, hi_a = _row_ends(ys_a - y0, xs_a, y1 - y0)
    lo_b, hi_b = _row_ends(ys_b - y0, xs_b, y1 - y0)
    both = (hi_a >= 0) & (hi_b >= 0)
    a_left = both & (hi_a < lo_b)
    rows = np.flatnonzero(a_left | (both & (hi_b < lo_a)))
    if rows.size < params.min_rows:
        return False
    # the last column of the left obstacle and the first of the right one, in each of those rows
    left_end = np.where(a_left, hi_a, hi_b)[rows]
    right_start = np.where(a_left, lo_b, lo_a)[rows]
    x0, x1 = int(left_end.min()) + 1, int(right_start.max())
    ys = rows + y0
    columns = np.arange(x0, x1)
    between = (columns > left_end[:, None]) & (columns < right_start[:, None])
    depth = disparity_to_depth(disparity[ys, x0:x1], calibration)
    # the depth of the farther of the two pixels that face each other across each row (fmin: a
    # missing one leaves the other; both missing, the row shows nothing)
    facing = disparity_to_depth(np.fmin(disparity[ys, left_end], disparity[ys, right_start])[:, None], calibration)
    matched = between & np.isfinite(depth)
    with np.errstate(invalid="ignore"):
        behind = matched & (depth > facing + gap_m)
    chroma = cue.chroma[ys, x0:x1].reshape(-1, 2).astype(np.int32)
    unlike = (chroma_apart(chroma, median_chroma[0], min_chroma_distance)
              & chroma_apart(chroma, median_chroma[1], min_chroma_distance)).reshape(between.shape)
    if all(np.count_nonzero(cue.coloured[pixels]) > 0.5 * len(pixels[0]) for pixels in (first, second)):
        unlike |= ~cue.coloured[ys, x0:x1]
    n_matched = matched.sum(axis=1)
    showing = (n_matched >= params.min_row_matched) & ((behind & unlike).sum(axis=1) >= params.min_row_fraction * n_matched)
    return int(showing.sum()) >= max(params.min_rows, params.min_rows_fraction * rows.size)


def _row_ends(rows: np.ndarray, xs: np.ndarray, height: int) -> tuple[np.ndarray, np.ndarray]:
    """Each row's first and last column (``int64 (height,)``) of the pixels in rows ``rows``
    (those outside ``0..height-1`` left out); a row without any has ``first`` beyond any column
    and ``last`` -1."""
    first = np.full(height, np.iinfo(np.int64).max)
    last = np.full(height, -1)
    inside = (rows >= 0) & (rows < height)               # the pixels in the rows both obstacles span
    np.minimum.at(first, rows[inside], xs[inside])
    np.maximum.at(last, rows[inside], xs[inside])
    return first, last
