"""Full-resolution refinement of a disparity estimate (the fine step of coarse-to-fine matching).

A disparity map found on a reduced copy of the pair and spread back over the full-size pixels
is right to within a pixel or two but carries the coarse resolution's errors (doubled at half
size). Each pixel with an estimate is matched again on the full-size images (NCC or MNCC on the
5 x 5 window, as in the growth): starting at the rounded estimate, moved into the admissible
range, it climbs to the better neighbouring disparity while that one is better and within
``radius`` of the start. It keeps the peak it reaches if the similarity there is at least
``tau``, with the parabola subpixel offset of :mod:`stereo_obstacles.subpixel`; a pixel whose
climb is stopped by the radius while still rising, or whose peak is below ``tau``, becomes
unmatched. Cost: 3 similarities per estimated pixel and one per step (about 3.2 on the
640x480 scene), in regular memory order, on ``n_threads`` row blocks (``docs/matching.md``,
"Coarse to fine").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stereo_obstacles._refinement_kernel import _refine_rows
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.similarity import SimilarityInputs
from stereo_obstacles.subpixel import parabola_offset
from stereo_obstacles.thread_pool import run_in_threads

__all__ = ["REFINE_RADIUS", "Refinement", "refine_disparity"]

REFINE_RADIUS = 2
"""Default half-width in pixels of the disparity window searched around each estimate
(``docs/matching.md``, "Coarse to fine": 2 gave lower bad-1 than 1 on Teddy and Cones)."""


@dataclass(frozen=True)
class Refinement:
    """Output of :func:`refine_disparity`.

    Attributes
    ----------
    disparity : ndarray of float32, shape (H, W)
        Refined disparity in pixels (subpixel), NaN where unmatched.
    integer_disparity : ndarray of int32, shape (H, W)
        The integer disparity before the subpixel offset, -1 where unmatched.
    similarity : ndarray of float32, shape (H, W)
        Similarity at the integer disparity, NaN where unmatched.
    n_computed : int
        Similarities computed.
    """

    disparity: np.ndarray
    integer_disparity: np.ndarray
    similarity: np.ndarray
    n_computed: int


def refine_disparity(inputs: SimilarityInputs, estimate: np.ndarray, *, tau: float, d_min: int, d_max: int,
                     radius: int = REFINE_RADIUS, n_threads: int = 1) -> Refinement:
    """Match every estimated pixel again near its estimate on the full-size images.

    Parameters
    ----------
    inputs : SimilarityInputs
        Prepared full-size images, shape (H, W).
    estimate : ndarray of float, shape (H, W)
        Disparity estimate in full-size pixels, NaN (or infinite) where there is none.
    tau : float
        A pixel keeps its best nearby disparity only if the similarity reaches this, in (0, 1).
    d_min, d_max : int
        Admissible disparities in pixels, inclusive.
    radius : int
        The climb stays within this many pixels of its start (>= 0).
    n_threads : int
        Row blocks matched in parallel threads, each with about as many estimated pixels (the
        result does not depend on it).

    Returns
    -------
    Refinement

    Examples
    --------
    >>> import numpy as np
    >>> from stereo_obstacles.similarity import prepare_similarity
    >>> right = np.random.default_rng(0).uniform(0, 255, (20, 40)).astype(np.float32)
    >>> left = np.roll(right, 3, axis=1)                    # true disparity 3
    >>> estimate = np.full(left.shape, 4.4, np.float32)     # one pixel off
    >>> refined = refine_disparity(prepare_similarity(left, right), estimate, tau=0.5, d_min=0, d_max=10)
    >>> round(float(np.nanmedian(refined.disparity)), 2)
    3.0
    """
    h, w = inputs.shape
    estimate = np.asarray(estimate)
    if estimate.shape != (h, w) or not np.issubdtype(estimate.dtype, np.floating):
        raise InvalidInputError(f"estimate: expected a float array of shape {(h, w)}, got "
                                f"{estimate.dtype} {estimate.shape}")
    if not 0.0 < tau < 1.0:
        raise InvalidInputError(f"tau: expected 0 < tau < 1, got {tau}")
    if int(radius) != radius or radius < 0:
        raise InvalidInputError(f"radius: expected an integer >= 0, got {radius}")
    if int(n_threads) != n_threads or n_threads < 1:
        raise InvalidInputError(f"n_threads: expected an integer >= 1, got {n_threads}")
    estimate = np.ascontiguousarray(estimate, np.float32)
    d_int = np.full((h, w), -1, np.int32)
    c, c_minus, c_plus = (np.full((h, w), np.nan, np.float32) for _ in range(3))
    # blocks of equal work: estimates crowd in the lower rows of a street scene (ground), not the sky
    work = np.cumsum(np.count_nonzero(estimate == estimate, axis=1))
    edges = [0] + [int(np.searchsorted(work, work[-1] * i / n_threads)) for i in range(1, int(n_threads))] + [h]
    counts = run_in_threads(_refine_rows, [(*inputs.kernel_args(), estimate, int(radius), float(tau), int(d_min),
                                            int(d_max), lo, hi, d_int, c, c_minus, c_plus)
                                           for lo, hi in zip(edges[:-1], edges[1:])])
    matched = d_int >= 0
    disparity = np.full((h, w), np.nan, np.float32)
    disparity[matched] = d_int[matched] + parabola_offset(c_minus[matched], c[matched], c_plus[matched])
    return Refinement(disparity, d_int, c, int(sum(counts)))
