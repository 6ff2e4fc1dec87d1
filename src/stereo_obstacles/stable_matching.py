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

from stereo_obstacles._stable_matching_kernel import _stable_matching_kernel
from stereo_obstacles.errors import InvalidInputError

__all__ = ["stable_matching"]


def stable_matching(y: np.ndarray, x: np.ndarray, x_right: np.ndarray, similarity: np.ndarray,
                    shape: tuple[int, int], *, margin: float = 0.1) -> np.ndarray:
    """Which candidates win the confidently stable matching.

    Parameters
    ----------
    y, x, x_right : ndarray of int, shape (N,)
        Candidate correspondences (left ``(x, y)``, right ``(x_right, y)``), all distinct.
    similarity : ndarray of float, shape (N,)
    shape : (H, W)
        Image shape; every coordinate must lie inside it.
    margin : float
        Relative confidence margin (>= 0).

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
    h, w = shape
    arrays = [np.ascontiguousarray(a, np.int32) for a in (y, x, x_right)]
    c = np.ascontiguousarray(similarity, np.float32)
    if any(a.shape != c.shape or a.ndim != 1 for a in arrays):
        raise InvalidInputError("y, x, x_right, similarity: expected 1-D arrays of one length")
    if not margin >= 0.0:
        raise InvalidInputError(f"margin: expected >= 0, got {margin}")
    if c.size and (arrays[0].min() < 0 or arrays[0].max() >= h
                   or min(arrays[1].min(), arrays[2].min()) < 0 or max(arrays[1].max(), arrays[2].max()) >= w):
        raise InvalidInputError(f"candidates: expected coordinates inside the {w}x{h} image")
    return _stable_matching_kernel(*arrays, c, h, w, float(margin))
