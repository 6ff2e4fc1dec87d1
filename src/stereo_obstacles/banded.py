"""Growth and final matching on horizontal row bands, one thread per band.

The image is cut into ``n_bands`` bands of equal height. Each band is grown on its own
(:func:`stereo_obstacles.growing.grow` on a view of the prepared images) from the seeds inside
it, over its own rows plus ``overlap`` rows of each neighbour, so that a surface reaching into a
band from a seed just across the border is still grown. The candidates of the rows a band owns
then go through the (row-independent) confidently stable matching and the subpixel look-ups of
that band. A band sees neither the candidates nor the ``mu`` and cap bookkeeping of the other
band beyond the overlap: the result is close to, not equal to, one growth over the whole image
(measured in ``docs/matching.md``). One band is the published single-queue growth.

The kernels release the GIL (``nogil``); the first band runs on the calling thread and the
others on a persistent pool, so a call wakes ``n_bands - 1`` idle threads.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.growing import grow
from stereo_obstacles.seeds import Seeds
from stereo_obstacles.similarity import RADIUS, SimilarityInputs
from stereo_obstacles.stable_matching import stable_matching
from stereo_obstacles.subpixel import parabola_offset
from stereo_obstacles.thread_pool import run_in_threads

__all__ = ["BandedMatch", "BAND_OVERLAP", "band_rows", "match_bands"]

BAND_OVERLAP = 16
"""Rows of each neighbouring band a band also grows over (see ``docs/matching.md``)."""

@dataclass(frozen=True)
class BandedMatch:
    """Winners of the final matching over every band, in image coordinates.

    Attributes
    ----------
    y, x, x_right : ndarray of int32, shape (M,)
        Matches: left ``(x, y)`` with right ``(x_right, y)``.
    similarity : ndarray of float32, shape (M,)
        Similarity of each match (as stored by the growth).
    offset : ndarray of float32, shape (M,)
        Subpixel offset of each match in pixels, in ``[-0.5, 0.5]``.
    n_candidates, n_computed, n_rescanned, n_overflow : int
        Sums over the bands (:class:`~stereo_obstacles.growing.Growth`); candidates are those of
        the rows each band owns, computed points include the overlap rows of both bands.
    growth_seconds : float
        Wall time from the start until the slowest band finished growing.
    matched_seconds : float
        Wall time from the start until the slowest band finished its final matching (the
        subpixel look-ups follow).
    """

    y: np.ndarray
    x: np.ndarray
    x_right: np.ndarray
    similarity: np.ndarray
    offset: np.ndarray
    n_candidates: int
    n_computed: int
    n_rescanned: int
    n_overflow: int
    growth_seconds: float
    matched_seconds: float

    def __post_init__(self) -> None:
        n = self.y.shape[0]
        if any(a.shape != (n,) for a in (self.x, self.x_right, self.similarity, self.offset)):
            raise InvalidInputError("y, x, x_right, similarity, offset: expected 1-D arrays of one length")


def band_rows(h: int, n_bands: int, overlap: int) -> list[tuple[int, int, int, int]]:
    """Rows of each band: ``(own_lo, own_hi, grow_lo, grow_hi)``, half-open, in image rows.

    Bands own equal shares of the ``h`` rows (at least one each) and grow over ``overlap`` more
    rows on each side, inside the image.

    Examples
    --------
    >>> band_rows(100, 2, 16)
    [(0, 50, 0, 66), (50, 100, 34, 100)]
    """
    if int(n_bands) != n_bands or n_bands < 1:
        raise InvalidInputError(f"n_bands: expected an integer >= 1, got {n_bands}")
    if int(overlap) != overlap or overlap < 0:
        raise InvalidInputError(f"overlap: expected an integer >= 0, got {overlap}")
    n = min(int(n_bands), h)
    edges = [round(i * h / n) for i in range(n + 1)]
    return [(lo, hi, max(0, lo - overlap), min(h, hi + overlap)) for lo, hi in zip(edges[:-1], edges[1:])]


def _band_inputs(inputs: SimilarityInputs, lo: int, hi: int) -> SimilarityInputs:
    """The prepared images of rows ``[lo, hi)`` (views; padded arrays keep their border rows)."""
    pad = 2 * RADIUS
    return SimilarityInputs(inputs.left_pad[lo:hi + pad], inputs.right_pad[lo:hi + pad], inputs.mean_l[lo:hi],
                            inputs.norm_l[lo:hi], inputs.mean_r[lo:hi], inputs.norm_r[lo:hi], inputs.kind)


def _match_band(inputs, seeds, scanned_hi, rows, options, t_start):
    """Grow one band, match its own rows; returns arrays in image rows, counters and stage end times."""
    own_lo, own_hi, lo, hi = rows
    inside = (seeds.y >= lo) & (seeds.y < hi)
    band_seeds = Seeds(seeds.y[inside] - lo, seeds.x[inside], seeds.x_right[inside], seeds.similarity[inside],
                       0, 0)
    growth = grow(_band_inputs(inputs, lo, hi), band_seeds, scanned_hi=scanned_hi[lo:hi], **options["grow"])
    t_grown = time.perf_counter() - t_start
    own = (growth.y >= own_lo - lo) & (growth.y < own_hi - lo)
    y, x, xr, c = growth.y[own], growth.x[own], growth.x_right[own], growth.similarity[own]
    if not options["greedy"]:
        won = stable_matching(y, x, xr, c, (hi - lo, inputs.shape[1]), margin=options["final_margin"])
        y, x, xr, c = y[won], x[won], xr[won], c[won]
    t_matched = time.perf_counter() - t_start
    c_minus, c_plus = growth.side_similarities(y, x, x - xr)
    counts = (int(own.sum()), growth.n_computed, growth.n_rescanned, growth.n_overflow)
    return (y + lo).astype(np.int32), x, xr, c, parabola_offset(c_minus, c, c_plus), counts, t_grown, t_matched


def match_bands(inputs: SimilarityInputs, seeds: Seeds, *, scanned_hi: np.ndarray, n_bands: int,
                overlap: int = BAND_OVERLAP, d_min: int, d_max: int, tau: float, mu: float,
                max_candidates: int, margin_reference: str, greedy: bool, final_margin: float) -> BandedMatch:
    """Grow, match and refine each row band in its own thread.

    Parameters
    ----------
    inputs : SimilarityInputs
        Prepared images, shape (H, W).
    seeds : Seeds
        Seeds in image coordinates; each band uses those in its rows (overlap included).
    scanned_hi : ndarray of int32, shape (H, W)
        Largest disparity a seed search evaluated per pixel (-1: none), for the visited count.
    n_bands : int
        Bands (threads), >= 1; 1 is one growth over the whole image.
    overlap : int
        Rows of each neighbour a band grows over, >= 0.
    d_min, d_max, tau, mu, max_candidates, margin_reference, greedy
        As :func:`stereo_obstacles.growing.grow`.
    final_margin : float
        Margin of :func:`stereo_obstacles.stable_matching.stable_matching` (ignored when greedy).

    Returns
    -------
    BandedMatch
    """
    h = inputs.shape[0]
    if scanned_hi.shape != inputs.shape:
        raise InvalidInputError(f"scanned_hi: expected shape {inputs.shape}, got {scanned_hi.shape}")
    bands = band_rows(h, n_bands, overlap)
    options = {"grow": dict(d_min=d_min, d_max=d_max, tau=tau, mu=mu, max_candidates=max_candidates,
                            margin_reference=margin_reference, greedy=greedy),
               "greedy": greedy, "final_margin": final_margin}
    t_start = time.perf_counter()
    parts = run_in_threads(_match_band, [(inputs, seeds, scanned_hi, rows, options, t_start) for rows in bands])
    y, x, xr, c, offset = (np.concatenate([p[k] for p in parts]) for k in range(5))
    counts = np.sum([p[5] for p in parts], axis=0)
    return BandedMatch(y, x, xr, c, offset, *(int(v) for v in counts), max(p[6] for p in parts),
                       max(p[7] for p in parts))
