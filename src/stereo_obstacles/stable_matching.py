"""The final decision of GCS: a confidently stable matching per scanline.

The candidate table holds several candidates per pixel. On each row, candidates are taken
best first (equal similarities in table order). A candidate whose left or right pixel is already decided is eliminated
(uniqueness). Otherwise it is the best remaining one at both its pixels; it wins when every
remaining competitor (a candidate sharing its left or its right pixel whose other pixel is
still free) is worse by more than ``margin * |c|``. If one is not, the pair is ambiguous:
both pixels stay unmatched. This leaves occlusions and repetitive texture out instead of
guessing.

Competitors one pixel away on the other side (``|x'_q - x'_p| <= 1`` for a shared left
pixel, ``|x_q - x_p| <= 1`` for a shared right pixel) are the same surface sampled at the
neighbouring integer disparity; they are eliminated but do not count as ambiguity
(otherwise every surface with a half-pixel disparity would be rejected; subpixel
refinement resolves them).

Cost: a counting sort of the candidates by row, a sort of each row by similarity and ``O(K)``
work per candidate.
"""

from __future__ import annotations

import numpy as np

from stereo_obstacles._stable_matching_kernel import _rows, _stable_matching_kernel
from stereo_obstacles.errors import InvalidInputError

__all__ = ["RowMatching", "stable_matching"]


class RowMatching:
    """The confidently stable matching of a candidate table, run row range by row range.

    The candidates are grouped by row once; :meth:`match_rows` then matches any range of rows
    (rows are independent, so calls on disjoint ranges may run in parallel threads, and
    together they give the winners of one call over every row).

    Parameters
    ----------
    y, x, x_right : ndarray of int, shape (N,)
        Candidate correspondences (left ``(x, y)``, right ``(x_right, y)``), all distinct.
    similarity : ndarray of float, shape (N,)
    shape : (H, W)
        Image shape; every coordinate must lie inside it.
    margin : float
        Relative confidence margin (>= 0).

    Attributes
    ----------
    winner : ndarray of bool, shape (N,)
        True for the winners of the rows matched so far.
    """

    def __init__(self, y: np.ndarray, x: np.ndarray, x_right: np.ndarray, similarity: np.ndarray,
                 shape: tuple[int, int], *, margin: float = 0.1) -> None:
        h, w = shape
        ys, xs, xrs = (np.ascontiguousarray(a, np.int32) for a in (y, x, x_right))
        c = np.ascontiguousarray(similarity, np.float32)
        if any(a.shape != c.shape or a.ndim != 1 for a in (ys, xs, xrs)):
            raise InvalidInputError("y, x, x_right, similarity: expected 1-D arrays of one length")
        if not margin >= 0.0:
            raise InvalidInputError(f"margin: expected >= 0, got {margin}")
        if c.size and (ys.min() < 0 or ys.max() >= h
                       or min(xs.min(), xrs.min()) < 0 or max(xs.max(), xrs.max()) >= w):
            raise InvalidInputError(f"candidates: expected coordinates inside the {w}x{h} image")
        self.shape = (h, w)
        self.winner = np.zeros(c.shape, np.bool_)
        self._table = (xs, xrs, c, *_rows(ys, h))
        self._margin = float(margin)

    def n_candidates(self, lo: int, hi: int) -> int:
        """Number of candidates in rows ``[lo, hi)``."""
        return int(self._table[3][hi] - self._table[3][lo])

    def row_cuts(self, lo: int, hi: int, n_pieces: int) -> list[int]:
        """Row edges ``lo = e0 <= e1 <= ... <= e_n = hi`` cutting rows ``[lo, hi)`` into ``n_pieces``
        ranges of about equal candidate counts (whole rows; empty ranges where one row holds more
        than a share)."""
        h = self.shape[0]
        if not 0 <= lo <= hi <= h:
            raise InvalidInputError(f"lo, hi: expected 0 <= lo <= hi <= {h}, got {lo}, {hi}")
        if int(n_pieces) != n_pieces or n_pieces < 1:
            raise InvalidInputError(f"n_pieces: expected an integer >= 1, got {n_pieces}")
        row_start = self._table[3]
        first, last = row_start[lo], row_start[hi]
        targets = first + (last - first) * np.arange(1, n_pieces) / n_pieces
        inner = np.clip(np.searchsorted(row_start[lo:hi + 1], targets), 0, hi - lo) + lo
        return [int(lo), *(int(e) for e in inner), int(hi)]

    def match_rows(self, lo: int, hi: int) -> np.ndarray:
        """Match the candidates of rows ``[lo, hi)``: their winners go to :attr:`winner` and are
        returned as indices (int64), row by row (in table order inside a row)."""
        h, w = self.shape
        if not 0 <= lo <= hi <= h:
            raise InvalidInputError(f"lo, hi: expected 0 <= lo <= hi <= {h}, got {lo}, {hi}")
        return _stable_matching_kernel(*self._table, w, self._margin, int(lo), int(hi), self.winner)


def stable_matching(y: np.ndarray, x: np.ndarray, x_right: np.ndarray, similarity: np.ndarray,
                    shape: tuple[int, int], *, margin: float = 0.1) -> np.ndarray:
    """Which candidates win the confidently stable matching (every row at once; the parameters
    are those of :class:`RowMatching`).

    Returns
    -------
    ndarray of bool, shape (N,)
        True for the winners; no two winners share a left or a right pixel of a row.

    Examples
    --------
    >>> import numpy as np
    >>> stable_matching(np.array([0, 0]), np.array([5, 5]), np.array([2, 4]),
    ...                 np.array([0.9, 0.5]), (1, 8)).tolist()
    [True, False]
    """
    matching = RowMatching(y, x, x_right, similarity, shape, margin=margin)
    matching.match_rows(0, matching.shape[0])
    return matching.winner
