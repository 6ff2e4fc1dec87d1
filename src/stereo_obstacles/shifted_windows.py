"""Shifted-window check of the final matches near depth edges (an extension of GCS, on by default).

A 5 x 5 window centred on a background pixel next to a textured foreground object is
dominated by the foreground, so the background pixel takes the foreground disparity
("foreground fattening", most of the GCS errors on Middlebury Cones). Following the idea of
Fusiello's symmetric multiple windows, the similarity of a match at disparity ``d`` is taken
as the best over nine windows that contain the pixel: centred on it and on the 8 pixels 2 px
away in each direction (the corners and edge midpoints of its 5 x 5 square), as Fusiello's
nine. A match is checked only where a neighbouring match (in its 5 x 5 square) has a disparity
more than 1 px away, and it is rejected when some such neighbouring disparity scores higher
than ``d`` at the pixel. Only matches next to a disparity jump pay for the check; the nine
windows at one disparity share the products of a 9 x 9 tile. Until session 13 all 25 windows
containing the pixel were tried: the nine give the same or lower bad-1 on the Middlebury pairs
in 0.8x the time (``docs/matching.md``).

A verdict depends only on the matches in the pixel's square, so the check runs strip by strip
of rows (:class:`ShiftedWindowCheck`): a strip can be checked as soon as the matches of its rows
and of the :data:`~stereo_obstacles.similarity.RADIUS` rows on each side are known, which lets
the row bands of :mod:`stereo_obstacles.banded` check while another band still grows.
"""

from __future__ import annotations

import cv2
import numpy as np

from stereo_obstacles._shifted_windows_kernel import (MAPS_OUTSIDE, MAPS_REPEATED, _add_match_map, _add_matches,
                                                       _check_rows_kernel, _count_jumps)
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.similarity import RADIUS, SimilarityInputs
from stereo_obstacles.thread_pool import run_in_threads

__all__ = ["STRIPS_PER_THREAD", "ShiftedWindowCheck", "shifted_window_check", "shifted_window_check_map"]

STRIPS_PER_THREAD = 8
"""Strips of rows per thread (:func:`shifted_window_check`, dealt out in turn) and per row band
(:mod:`stereo_obstacles.banded`, taken by whichever thread is free). Matches next to depth edges
bunch in some rows: one strip per thread left one thread with up to 60 % of the work, and with
4 per band the last strip of Teddy's bottom rows alone took 1.9 ms (1.1 ms with 8)."""

_SQUARE = np.ones((2 * RADIUS + 1, 2 * RADIUS + 1), np.uint8)


class ShiftedWindowCheck:
    """The shifted-window check of one image's final matches, filled in and run by rows.

    :meth:`add` writes matches into integer disparity maps of the whole image; :meth:`check_rows`
    then checks the matches of a strip of rows, once every match of those rows and of the
    :data:`RADIUS` rows on each side has been added. Calls on disjoint rows may run in parallel
    threads (the kernels release the GIL and write only their own rows). The verdicts do not
    depend on how the rows are cut.

    Parameters
    ----------
    inputs : SimilarityInputs
        Prepared images, shape (H, W).
    """

    def __init__(self, inputs: SimilarityInputs) -> None:
        h, w = inputs.shape
        self.inputs = inputs
        self.d_map = np.full((h, w), -1, np.int32)
        self._for_max = np.full((h, w), -1.0, np.float32)
        self._for_min = np.full((h, w), np.inf, np.float32)
        self.rejected = np.zeros((h, w), np.bool_)
        self._jumps = np.zeros(h, np.int64)

    def add(self, y: np.ndarray, x: np.ndarray, d: np.ndarray) -> None:
        """Add matches: left pixels ``(x, y)`` (int, shape (N,), each at most once over all calls)
        with integer disparities ``d`` in pixels (>= 0, right pixel ``x - d`` inside the image)."""
        ys, xs, ds = (np.ascontiguousarray(a, np.int64).ravel() for a in (y, x, d))
        if not ys.shape == xs.shape == ds.shape:
            raise InvalidInputError(f"y, x, d: expected one length, got {ys.shape}, {xs.shape}, {ds.shape}")
        self.add_from_table(ys, xs, xs - ds, np.arange(ys.size))

    def add_from_table(self, y: np.ndarray, x: np.ndarray, x_right: np.ndarray, index: np.ndarray,
                       row_offset: int = 0) -> None:
        """Add the matches ``index`` (int, shape (M,)) of a table of correspondences: left pixels
        ``(x, y + row_offset)`` and right columns ``x_right`` (1-D int arrays of one length), with
        the conditions of :meth:`add`. Reads the table in place (the final matching's pieces add
        their winners so, without gathering them first)."""
        y, x, x_right, index = (np.asarray(a) for a in (y, x, x_right, index))
        if not (y.ndim == 1 and y.shape == x.shape == x_right.shape and index.ndim == 1):
            raise InvalidInputError("y, x, x_right, index: expected 1-D arrays, the first three of "
                                    "one length")
        if any(a.dtype.kind != "i" for a in (y, x, x_right)) or index.dtype.kind not in "iu":
            raise InvalidInputError("y, x, x_right, index: expected signed integer arrays (index: "
                                    "any integers)")
        if index.size and not (0 <= index.min() and index.max() < y.size):
            raise InvalidInputError(f"index: expected entries in [0, {y.size})")
        self._raise_for(_add_matches(y, x, x_right, index, int(row_offset), self.d_map, self._for_max, self._for_min))

    def add_map(self, disparity: np.ndarray) -> None:
        """Add the matches of a whole image at once: ``disparity`` (int32, shape (H, W)) holds each
        left pixel's integer disparity in pixels, negative where unmatched (a negative disparity,
        which a negative ``min_disparity`` allows, is not checked), with the other conditions of
        :meth:`add` (5x faster than :meth:`add` of the same matches: no lists of pixels)."""
        disparity = np.asarray(disparity)
        if disparity.shape != self.d_map.shape or disparity.dtype != np.int32:
            raise InvalidInputError(f"disparity: expected int32 of shape {self.d_map.shape}, got {disparity.dtype} "
                                    f"of shape {disparity.shape}")
        self._raise_for(_add_match_map(disparity, self.d_map, self._for_max, self._for_min))

    def _raise_for(self, status: int) -> None:
        """:class:`InvalidInputError` for a failed status of the kernels that add matches."""
        if status == MAPS_OUTSIDE:
            h, w = self.d_map.shape
            raise InvalidInputError(f"matches: expected left and right pixels inside the {w}x{h} image, "
                                    f"the right one not right of the left one (disparity >= 0)")
        if status == MAPS_REPEATED:
            raise InvalidInputError("matches: expected each left pixel at most once over all additions")

    def count_jumps(self, lo: int, hi: int) -> None:
        """Count, for :meth:`jumps_near`, the disparity jumps of image rows ``[lo, hi)`` once all their
        matches are added."""
        h = self.d_map.shape[0]
        if not 0 <= lo <= hi <= h:
            raise InvalidInputError(f"lo, hi: expected 0 <= lo <= hi <= {h}, got {lo}, {hi}")
        _count_jumps(self.d_map, int(lo), int(hi), self._jumps)

    def jumps_near(self, lo: int, hi: int) -> int:
        """Pairs of horizontally neighbouring matches more than 1 px of disparity apart in image rows
        ``[lo - RADIUS, hi + RADIUS)`` (rows counted by :meth:`count_jumps`): a measure of the work of
        :meth:`check_rows`, which compares only matches next to a disparity jump (on Teddy's lower
        band the strips' check times follow it, 0.2 ms at 26 such pairs to 1.05 ms at 107)."""
        return int(self._jumps[max(0, lo - RADIUS):hi + RADIUS].sum())

    def check_rows(self, lo: int, hi: int) -> int:
        """Check the matches of image rows ``[lo, hi)`` (their verdicts go to :attr:`rejected`);
        returns how many had a neighbouring disparity to compare with."""
        h = self.d_map.shape[0]
        if not 0 <= lo <= hi <= h:
            raise InvalidInputError(f"lo, hi: expected 0 <= lo <= hi <= {h}, got {lo}, {hi}")
        if lo == hi:
            return 0
        # smallest and largest disparity in the square around each pixel of the rows (exact:
        # disparities < 2^24), from the maps of those rows and the RADIUS rows on each side
        top, bottom = max(0, lo - RADIUS), min(h, hi + RADIUS)
        sq_hi = cv2.dilate(self._for_max[top:bottom], _SQUARE, borderType=cv2.BORDER_CONSTANT, borderValue=-1.0)
        sq_lo = cv2.erode(self._for_min[top:bottom], _SQUARE, borderType=cv2.BORDER_CONSTANT, borderValue=np.inf)
        return _check_rows_kernel(*self.inputs.kernel_args(), self.d_map, sq_lo, sq_hi, top, lo, hi, self.rejected)

    def keep(self, y: np.ndarray, x: np.ndarray) -> np.ndarray:
        """False for the matches at left pixels ``(x, y)`` the check rejected (bool, shaped like ``y``)."""
        h, w = self.rejected.shape
        y, x = np.asarray(y), np.asarray(x)
        if y.size and not (0 <= y.min() and y.max() < h and 0 <= x.min() and x.max() < w):
            raise InvalidInputError(f"y, x: expected pixels inside the {w}x{h} image")
        return ~self.rejected.ravel().take(y.astype(np.int64) * w + x)  # 2x faster than rejected[y, x]


def shifted_window_check(inputs: SimilarityInputs, y: np.ndarray, x: np.ndarray,
                         d: np.ndarray, *, n_threads: int = 1) -> tuple[np.ndarray, int]:
    """Which matches survive the shifted-window check.

    Parameters
    ----------
    inputs : SimilarityInputs
        Prepared images, shape (H, W).
    y, x : ndarray of int, shape (N,)
        Left pixels of the matches, each at most once, inside the image.
    d : ndarray of int, shape (N,)
        Integer disparities in pixels (>= 0; the right pixel ``x - d`` inside the image).
    n_threads : int
        Threads; with more than one, the rows are checked in :data:`STRIPS_PER_THREAD` strips per
        thread, dealt out in turn (the result does not depend on it).

    Returns
    -------
    keep : ndarray of bool, shape (N,)
        False for the matches a neighbouring disparity beats.
    n_checked : int
        Matches that had a neighbouring disparity to compare with.

    Examples
    --------
    >>> import numpy as np
    >>> from stereo_obstacles.similarity import prepare_similarity
    >>> img = np.random.default_rng(0).uniform(0, 255, (12, 20)).astype(np.float32)
    >>> inputs = prepare_similarity(img, img)
    >>> keep, n_checked = shifted_window_check(inputs, np.array([5]), np.array([8]), np.array([0]))
    >>> keep.tolist(), n_checked
    ([True], 0)
    """
    _check_thread_count(n_threads)
    check = ShiftedWindowCheck(inputs)
    check.add(y, x, d)
    n_checked = _check_every_row(check, int(n_threads))
    return check.keep(np.asarray(y).ravel(), np.asarray(x).ravel()), n_checked


def shifted_window_check_map(inputs: SimilarityInputs, disparity: np.ndarray, *,
                             n_threads: int = 1) -> tuple[np.ndarray, int]:
    """:func:`shifted_window_check` of the matches of a whole image given as a map.

    Parameters
    ----------
    inputs : SimilarityInputs
        Prepared images, shape (H, W).
    disparity : ndarray of int32, shape (H, W)
        Each left pixel's integer disparity in pixels (``x - d >= 0``), negative where unmatched
        (as in :meth:`ShiftedWindowCheck.add_map`).
    n_threads : int
        As for :func:`shifted_window_check`.

    Returns
    -------
    rejected : ndarray of bool, shape (H, W)
        True at the matches a neighbouring disparity beats.
    n_checked : int
        Matches that had a neighbouring disparity to compare with.
    """
    _check_thread_count(n_threads)
    check = ShiftedWindowCheck(inputs)
    check.add_map(disparity)
    n_checked = _check_every_row(check, int(n_threads))
    return check.rejected, n_checked


def _check_thread_count(n_threads: int) -> None:
    if int(n_threads) != n_threads or n_threads < 1:
        raise InvalidInputError(f"n_threads: expected an integer >= 1, got {n_threads}")


def _check_every_row(check: ShiftedWindowCheck, n_threads: int) -> int:
    """Check every row of ``check`` on ``n_threads`` threads, in :data:`STRIPS_PER_THREAD` strips
    per thread dealt out in turn (one strip for one thread); returns the matches compared."""
    h = check.d_map.shape[0]
    n_strips = 1 if n_threads == 1 else STRIPS_PER_THREAD * n_threads
    edges = [round(i * h / n_strips) for i in range(n_strips + 1)]
    strips = list(zip(edges[:-1], edges[1:]))
    return sum(run_in_threads(_check_strips, [(check, strips[t::n_threads]) for t in range(n_threads)]))


def _check_strips(check: ShiftedWindowCheck, strips: list[tuple[int, int]]) -> int:
    return sum(check.check_rows(lo, hi) for lo, hi in strips)
