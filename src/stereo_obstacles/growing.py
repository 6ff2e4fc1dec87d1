"""Growing correspondence seeds: best-first growth of the candidate table over disparity space.

From the best point ``s = (x, x', y)`` in the queue, each of the four neighbourhood groups

* N1 = {(x-1, x'-1), (x-2, x'-1), (x-1, x'-2)} on row y,
* N2 = {(x+1, x'+1), (x+2, x'+1), (x+1, x'+2)} on row y,
* N3 = {(x, x'), (x-1, x'), (x+1, x'), (x, x'-1), (x, x'+1)} on row y-1,
* N4 = the same on row y+1

offers its best point ``q``. ``q`` joins the candidate table (and the queue) when

* ``c(q) >= tau``, ``q`` is not yet a candidate,
* its left and its right pixel have fewer than ``max_candidates`` candidates,
* ``c(q) + mu >= ref``, where ``ref`` is the best candidate similarity so far at its
  left pixel and at its right pixel, combined with ``max`` (default) or ``min``
  (``margin_reference``).

The greedy variant instead accepts ``q`` only when both its pixels are still unmatched, and
the candidate table is then the matching itself. Seeds enter first, without the ``mu`` test.
Every point's similarity is computed at most once (see ``_growing_kernel``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stereo_obstacles._growing_kernel import (COUNT_BLOCKS, COUNT_COMPUTED, COUNT_MASK, COUNT_OVERFLOW, COUNT_RESCANNED,
                                                 MAX_CODE, MAX_COUNT, _grow_kernel, _side_similarities,
                                                 buffer_size)
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.seeds import NOT_SCANNED, Seeds
from stereo_obstacles.similarity import SimilarityInputs

__all__ = ["MARGIN_REFERENCES", "MEMO_SLOTS", "QUEUE_BUCKETS", "Growth", "grow"]

MARGIN_REFERENCES = ("max", "min")
"""How the left and right per-pixel bests combine in the ``mu`` test."""

MEMO_SLOTS = 24
"""Memoised disparities per left pixel (more are computed but not stored, and counted); at most
31, the count a pixel record holds (``_growing_kernel.COUNT_MASK``)."""
assert MEMO_SLOTS <= COUNT_MASK

QUEUE_BUCKETS = 8
"""Similarity steps of the bucket priority queue on ``[tau, 1]`` (LIFO inside a step).

Coarse on purpose: the queue pops a candidate within one step (0.057 at ``tau`` 0.6, about
half the growth margin ``mu``) of the best, and consecutive pops then tend to be neighbours,
which the memory-bound growth rewards: 25-30 % less growth time than 4096 steps with bad-1 and
density unchanged to within 0.03 points on the Middlebury pairs (``docs/matching.md``)."""


@dataclass(frozen=True)
class Growth:
    """The candidate table after growth, and the memo to look similarities up in.

    Attributes
    ----------
    y, x, x_right : ndarray of int32, shape (N,)
        Candidate correspondences.
    similarity : ndarray of float32, shape (N,)
        As stored by the growth: a multiple of ``1 / 32767`` (see ``_growing_kernel.QUANT``).
    inputs : SimilarityInputs
        The prepared images the similarities were computed on.
    d_min, d_max : int
        Admissible disparities in pixels, inclusive.
    scanned_hi : ndarray of int32, shape (H, W)
        Largest disparity a seed scanline search evaluated at each pixel,
        :data:`~stereo_obstacles.seeds.NOT_SCANNED` where none.
    n_computed : int
        Distinct points whose similarity was computed during growth (and any later
        :meth:`side_similarities` call).
    n_rescanned : int
        Of those, points a seed scanline search had already evaluated (see ``scanned_hi`` of
        :func:`grow`), so that visited points can be counted once.
    n_overflow : int
        Points computed at a pixel whose memo slots were full (computed again if met again).
    n_memo_blocks : int
        Memo overflow blocks in use (see ``_growing_kernel``).
    """

    y: np.ndarray
    x: np.ndarray
    x_right: np.ndarray
    similarity: np.ndarray
    inputs: SimilarityInputs
    d_min: int
    d_max: int
    scanned_hi: np.ndarray
    _memo: tuple

    def __post_init__(self) -> None:
        n = self.y.shape[0]
        if any(a.shape != (n,) for a in (self.x, self.x_right, self.similarity)):
            raise InvalidInputError("y, x, x_right, similarity: expected 1-D arrays of one length")

    @property
    def n_computed(self) -> int:
        return int(self._memo[-1][COUNT_COMPUTED])

    @property
    def n_rescanned(self) -> int:
        return int(self._memo[-1][COUNT_RESCANNED])

    @property
    def n_overflow(self) -> int:
        return int(self._memo[-1][COUNT_OVERFLOW])

    @property
    def n_memo_blocks(self) -> int:
        return int(self._memo[-1][COUNT_BLOCKS])

    def side_similarities(self, y: np.ndarray, x: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Similarity at disparities ``d - 1`` and ``d + 1`` of left pixels ``(x, y)``.

        Looked up in the memo, computed (and counted, not stored) when absent; NaN outside
        the image or the disparity range. Returns two float32 arrays shaped like ``y``.
        """
        shape = np.shape(y)
        args = [np.ascontiguousarray(a, np.int32).ravel() for a in (y, x, d)]
        c_minus, c_plus = _side_similarities(*self.inputs.kernel_args(), *self._memo, self.scanned_hi, *args,
                                             self.d_min, self.d_max)
        return c_minus.reshape(shape), c_plus.reshape(shape)


def grow(inputs: SimilarityInputs, seeds: Seeds, *, d_min: int, d_max: int, tau: float = 0.6,
         mu: float = 0.1, max_candidates: int = 10, margin_reference: str = "max",
         greedy: bool = False, scanned_hi: np.ndarray | None = None,
         queue_buckets: int = QUEUE_BUCKETS) -> Growth:
    """Grow the seeds into a candidate table.

    Parameters
    ----------
    inputs : SimilarityInputs
        Prepared images (:func:`~stereo_obstacles.similarity.prepare_similarity`).
    seeds : Seeds
        Starting correspondences; those below ``tau`` are ignored.
    d_min, d_max : int
        Admissible disparities in pixels, inclusive.
    tau : float
        Similarity threshold in (0, 1).
    mu : float
        Margin of the growth test (>= 0).
    max_candidates : int
        Cap ``K`` on candidates per left and per right pixel (>= 1).
    margin_reference : {"max", "min"}
        Combination of the left and right bests in the ``mu`` test.
    greedy : bool
        Greedy variant: the candidate table is a one-to-one matching.
    scanned_hi : ndarray of int32, shape (H, W), optional
        Largest disparity a seed scanline search evaluated at each pixel (:data:`NOT_SCANNED`:
        none); only used to count the visited points once (:attr:`Growth.n_rescanned`).
    queue_buckets : int
        Similarity steps of the priority queue (see :data:`QUEUE_BUCKETS`), >= 1.

    Returns
    -------
    Growth
    """
    if margin_reference not in MARGIN_REFERENCES:
        raise InvalidInputError(f"margin_reference: expected one of {list(MARGIN_REFERENCES)}, "
                                f"got {margin_reference!r}")
    order = np.argsort(-seeds.similarity, kind="stable")
    seed_arrays = [np.ascontiguousarray(a[order]) for a in (seeds.y, seeds.x, seeds.x_right)]
    keep = seeds.similarity[order] >= tau
    seed_arrays = [a[keep] for a in seed_arrays]
    # clamped as computed similarities are: a seed's value above 1 (rounding; seeds from outside)
    # would wrap round in the int16 store and fall below tau
    seed_c = np.ascontiguousarray(np.clip(seeds.similarity[order][keep], -1.0, 1.0), np.float32)
    if d_max - d_min > MAX_CODE:
        raise InvalidInputError(f"d_min, d_max: the range must span at most {MAX_CODE + 1} disparities, got "
                                f"[{d_min}, {d_max}]")
    if max_candidates > MAX_COUNT:
        raise InvalidInputError(f"max_candidates: expected at most {MAX_COUNT}, got {max_candidates}")
    if int(queue_buckets) != queue_buckets or queue_buckets < 1:
        raise InvalidInputError(f"queue_buckets: expected an integer >= 1, got {queue_buckets}")
    if scanned_hi is None:
        scanned_hi = np.full(inputs.shape, NOT_SCANNED, np.int32)
    elif scanned_hi.shape != inputs.shape:
        raise InvalidInputError(f"scanned_hi: expected shape {inputs.shape}, got {scanned_hi.shape}")
    scanned_hi = np.ascontiguousarray(scanned_hi, np.int32)
    # allocated by NumPy, which asks the kernel for transparent huge pages: the growth is
    # bound by memory latency and 4 kB pages cost a TLB miss on most record visits
    buf = np.empty(buffer_size(*inputs.shape, MEMO_SLOTS), np.int16)
    t_y, t_x, t_xr, t_c, *memo = _grow_kernel(
        *inputs.kernel_args(), *seed_arrays, seed_c, scanned_hi, buf,
        int(d_min), int(d_max), float(tau), float(mu),
        int(max_candidates), margin_reference == "max", bool(greedy), MEMO_SLOTS, int(queue_buckets))
    return Growth(t_y, t_x, t_xr, t_c, inputs, int(d_min), int(d_max), scanned_hi, tuple(memo))
