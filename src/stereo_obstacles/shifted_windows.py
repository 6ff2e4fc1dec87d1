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
"""

from __future__ import annotations

import cv2
import numpy as np

from stereo_obstacles._shifted_windows_kernel import (MAPS_OUTSIDE, MAPS_REPEATED, _disparity_maps, _near_jump,
                                                       _shifted_window_kernel)
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.similarity import RADIUS, SimilarityInputs
from stereo_obstacles.thread_pool import run_in_threads

__all__ = ["shifted_window_check"]


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
        The matches next to a disparity jump are checked in up to this many equal chunks, one
        thread each (the result does not depend on it).

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
    h, w = inputs.shape
    if int(n_threads) != n_threads or n_threads < 1:
        raise InvalidInputError(f"n_threads: expected an integer >= 1, got {n_threads}")
    ys, xs, ds = (np.ascontiguousarray(a, np.int64).ravel() for a in (y, x, d))
    if not ys.shape == xs.shape == ds.shape:
        raise InvalidInputError(f"y, x, d: expected one length, got {ys.shape}, {xs.shape}, {ds.shape}")
    d_map, for_max, for_min, status = _disparity_maps(ys, xs, ds, h, w)
    if status == MAPS_OUTSIDE:
        raise InvalidInputError(f"y, x, d: expected matches inside the {w}x{h} image with d >= 0 and x - d >= 0")
    if status == MAPS_REPEATED:
        raise InvalidInputError("y, x: expected each left pixel at most once")
    # smallest and largest disparity in the square around each pixel (exact: disparities < 2^24)
    square = np.ones((2 * RADIUS + 1, 2 * RADIUS + 1), np.uint8)
    sq_hi = cv2.dilate(for_max, square, borderType=cv2.BORDER_CONSTANT, borderValue=-1.0)
    sq_lo = cv2.erode(for_min, square, borderType=cv2.BORDER_CONSTANT, borderValue=np.inf)
    # only the matches next to a jump are handed to the threads, in equal shares (6-10 % of them
    # on the Middlebury pairs, bunched along depth edges)
    near_jump = _near_jump(ys, xs, ds, sq_lo, sq_hi)
    keep = np.ones(ys.size, np.bool_)
    if near_jump.size == 0:
        return keep, 0
    edges = np.linspace(0, near_jump.size, min(int(n_threads), near_jump.size) + 1).astype(int)
    parts = run_in_threads(_shifted_window_kernel, [
        (*inputs.kernel_args(), d_map, sq_lo, sq_hi, ys[near_jump[lo:hi]], xs[near_jump[lo:hi]])
        for lo, hi in zip(edges[:-1], edges[1:])])
    keep[near_jump] = np.concatenate([p[0] for p in parts])
    return keep, int(sum(p[1] for p in parts))
