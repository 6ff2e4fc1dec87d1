"""Growth and final matching on horizontal row bands, one thread per band.

The image is cut into ``n_bands`` bands of equal height. Each band is grown on its own
(:func:`stereo_obstacles.growing.grow` on a view of the prepared images) from the seeds inside
it, over its own rows plus ``overlap`` rows of each neighbour, so that a surface reaching into a
band from a seed just across the border is still grown. The candidates of the rows a band owns
then go through the (row-independent) confidently stable matching and the subpixel look-ups of
that band. The shifted-window check (:mod:`stereo_obstacles.shifted_windows`) runs in strips of
rows that the band threads take as soon as the final matches around a strip are in: a band
that finishes growing first checks its own rows while the other still grows, then shares the
other band's strips with it. Its verdicts are those of one check over the whole image. A band
sees neither the candidates nor the ``mu`` and cap bookkeeping of the other
band beyond the overlap: the result is close to, not equal to, one growth over the whole image
(measured in ``docs/matching.md``). One band is the published single-queue growth.

The kernels release the GIL (``nogil``); the first band runs on the calling thread and the
others on a persistent pool, so a call wakes ``n_bands - 1`` idle threads.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass

import numpy as np

from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.growing import grow
from stereo_obstacles.seeds import Seeds
from stereo_obstacles.shifted_windows import STRIPS_PER_THREAD, ShiftedWindowCheck
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
    n_edge_checked, n_edge_rejected : int
        Matches the shifted-window check compared with a neighbouring disparity, and rejected
        (0 without the check); the rejected ones are not in the arrays above.
    growth_seconds : float
        Wall time from the start until the slowest band finished growing.
    matched_seconds : float
        Wall time from the start until the slowest band finished its final matching.
    checked_seconds : float
        Wall time from the start until the last strip of the shifted-window check was checked
        (``matched_seconds`` without the check).
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
    n_edge_checked: int
    n_edge_rejected: int
    growth_seconds: float
    matched_seconds: float
    checked_seconds: float

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


class _CheckStrips:
    """The shifted-window check's strips of rows, handed out to the band threads.

    Each band's own rows are cut into :data:`~stereo_obstacles.shifted_windows.STRIPS_PER_THREAD`
    strips; a strip can be checked once every band owning one of its rows or of the ``RADIUS``
    rows around it has added its final matches. A thread waits for a strip only while a band it
    needs is running (so a call whose bands run one after the other on one thread never waits).
    """

    def __init__(self, inputs: SimilarityInputs, bands: list[tuple[int, int, int, int]]) -> None:
        self.check = ShiftedWindowCheck(inputs)
        self.todo = []
        for own_lo, own_hi, _, _ in bands:
            edges = [own_lo + round(i * (own_hi - own_lo) / STRIPS_PER_THREAD) for i in range(STRIPS_PER_THREAD + 1)]
            for lo, hi in zip(edges[:-1], edges[1:]):
                if hi > lo:
                    needs = [b for b, rows in enumerate(bands) if rows[0] < hi + RADIUS and rows[1] > lo - RADIUS]
                    self.todo.append((lo, hi, needs))
        self.state = ["waiting"] * len(bands)
        self.n_checked = 0
        self.last_end = 0.0
        self._changed = threading.Condition()

    def set_state(self, band: int, state: str) -> None:
        """Mark a band ``"running"``, ``"added"`` or ``"failed"``, waking the waiting threads."""
        with self._changed:
            self.state[band] = state
            self._changed.notify_all()

    def add(self, band: int, y: np.ndarray, x: np.ndarray, d: np.ndarray) -> None:
        """Add a band's final matches (image rows)."""
        self.check.add(y, x, d)
        self.set_state(band, "added")

    def _next_strip(self, wait: bool):
        with self._changed:
            while self.todo:
                for k, (lo, hi, needs) in enumerate(self.todo):
                    if all(self.state[b] == "added" for b in needs):
                        del self.todo[k]
                        return lo, hi
                pending = {self.state[b] for _, _, needs in self.todo for b in needs}
                if not wait or "running" not in pending or "failed" in pending:
                    return None
                self._changed.wait()
            return None

    def work(self, *, wait: bool) -> None:
        """Check every strip that is ready; with ``wait``, also those whose bands are still running."""
        while (strip := self._next_strip(wait)) is not None:
            n = self.check.check_rows(*strip)
            with self._changed:
                self.n_checked += n
                self.last_end = max(self.last_end, time.perf_counter())


def _match_band(inputs, seeds, scanned_hi, band, rows, options, strips, t_start):
    """Grow one band, match its own rows, hand the matches to the check; returns arrays in
    image rows, counters and stage end times."""
    own_lo, own_hi, lo, hi = rows
    if strips is not None:
        strips.set_state(band, "running")
    try:
        inside = (seeds.y >= lo) & (seeds.y < hi)
        band_seeds = Seeds(seeds.y[inside] - lo, seeds.x[inside], seeds.x_right[inside], seeds.similarity[inside],
                           0, 0)
        growth = grow(inputs.rows(lo, hi), band_seeds, scanned_hi=scanned_hi[lo:hi], **options["grow"])
        t_grown = time.perf_counter() - t_start
        # index lists and take(): a boolean mask that keeps ~60 % of the entries at random (the
        # winners) indexes several times slower, 0.8 ms per array on Teddy
        own = np.flatnonzero((growth.y >= own_lo - lo) & (growth.y < own_hi - lo))
        y, x, xr, c = (a.take(own) for a in (growth.y, growth.x, growth.x_right, growth.similarity))
        if not options["greedy"]:
            won = np.flatnonzero(stable_matching(y, x, xr, c, (hi - lo, inputs.shape[1]),
                                                 margin=options["final_margin"]))
            y, x, xr, c = (a.take(won) for a in (y, x, xr, c))
        t_matched = time.perf_counter() - t_start
        y_image = (y + lo).astype(np.int32)
        if strips is not None:
            strips.add(band, y_image, x, x - xr)
            strips.work(wait=False)
    except BaseException:
        if strips is not None:
            strips.set_state(band, "failed")
        raise
    c_minus, c_plus = growth.side_similarities(y, x, x - xr)
    offset = parabola_offset(c_minus, c, c_plus)
    if strips is not None:
        strips.work(wait=True)  # the strips of bands still growing
    counts = (own.size, growth.n_computed, growth.n_rescanned, growth.n_overflow)
    return y_image, x, xr, c, offset, counts, t_grown, t_matched


def match_bands(inputs: SimilarityInputs, seeds: Seeds, *, scanned_hi: np.ndarray, n_bands: int,
                overlap: int = BAND_OVERLAP, d_min: int, d_max: int, tau: float, mu: float,
                max_candidates: int, margin_reference: str, greedy: bool, final_margin: float,
                shifted_windows: bool = False) -> BandedMatch:
    """Grow, match, check and refine each row band in its own thread.

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
    shifted_windows : bool
        Run the shifted-window check (:func:`stereo_obstacles.shifted_windows.shifted_window_check`)
        and drop the matches it rejects.

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
    strips = _CheckStrips(inputs, bands) if shifted_windows else None
    t_start = time.perf_counter()
    parts = run_in_threads(_match_band, [(inputs, seeds, scanned_hi, band, rows, options, strips, t_start)
                                         for band, rows in enumerate(bands)])
    y, x, xr, c, offset = (np.concatenate([p[k] for p in parts]) for k in range(5))
    counts = [int(v) for v in np.sum([p[5] for p in parts], axis=0)]
    matched_seconds = max(p[7] for p in parts)
    n_checked = n_rejected = 0
    checked_seconds = matched_seconds
    if strips is not None:
        keep = strips.check.keep(y, x)
        n_checked, n_rejected = strips.n_checked, int(keep.size - np.count_nonzero(keep))
        checked_seconds = strips.last_end - t_start
        if n_rejected:
            kept = np.flatnonzero(keep)
            y, x, xr, c, offset = (a.take(kept) for a in (y, x, xr, c, offset))
    return BandedMatch(y, x, xr, c, offset, *counts, n_checked, n_rejected, max(p[6] for p in parts),
                       matched_seconds, checked_seconds)
