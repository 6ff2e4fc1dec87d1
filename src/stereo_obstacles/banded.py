"""Growth and final matching on horizontal row bands, one thread per band.

The image is cut into ``n_bands`` bands of rows, the lower ones thinner (:data:`LOWER_ROWS_COST`).
Each band is grown on its own (:func:`stereo_obstacles.growing.grow` on a view of the prepared
images) from the seeds inside it, over its own rows plus ``overlap`` rows of each neighbour, so
that a surface reaching into a band from a seed just across the border is still grown. The candidates of the rows a band owns
then go through the (row-independent) confidently stable matching, the shifted-window check
(:mod:`stereo_obstacles.shifted_windows`) and the subpixel look-ups of that band.

The growth of the bands still takes unequal times (Teddy, bands at 54 % of the rows: about 15 and
18 ms), so the work after it is cut into pieces any thread may take (:class:`_SharedWork`): a
band's final matching in :data:`FINAL_PIECES` pieces of rows, and the check in strips of rows
handed out as soon as the final matches around a strip are in. A thread that has finished its
band takes the pieces and strips of the band still running, and does its own subpixel look-ups
last. Neither the winners nor the verdicts depend on who runs what.

A band sees neither the candidates nor the ``mu`` and cap bookkeeping of the other band beyond
the overlap: the result is close to, not equal to, one growth over the whole image (measured in
``docs/matching.md``). One band is the published single-queue growth.

The kernels release the GIL (``nogil``); the first band runs on the calling thread and the
others on a persistent pool, so a call wakes ``n_bands - 1`` idle threads.
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass

import numpy as np

from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.growing import grow
from stereo_obstacles.seeds import Seeds
from stereo_obstacles.shifted_windows import STRIPS_PER_THREAD, ShiftedWindowCheck
from stereo_obstacles.similarity import RADIUS, SimilarityInputs
from stereo_obstacles.stable_matching import RowMatching
from stereo_obstacles.subpixel import parabola_offset
from stereo_obstacles.thread_pool import run_in_threads

__all__ = ["BandedMatch", "BAND_OVERLAP", "FINAL_PIECES", "LOWER_ROWS_COST", "band_rows", "match_bands"]

BAND_OVERLAP = 4
"""Rows of each neighbouring band a band also grows over (see ``docs/matching.md``): 16 until
session 14, 8 until session 15; each halving gave the same accuracy (Middlebury, Aloe, KITTI, 90
synthetic scenes) and 1-3 % less match time."""

@dataclass(frozen=True)
class BandedMatch:
    """Winners of the final matching over every band, in image coordinates.

    Attributes
    ----------
    y, x, x_right : ndarray of int32, shape (M,)
        Matches: left ``(x, y)`` with right ``(x_right, y)``, row by row.
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
        Wall time from the start until the last strip of the shifted-window check was checked,
        and not less than ``matched_seconds`` (a band's own clock can stop after the other
        threads checked its last strip; equal to it without the check).
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


LOWER_ROWS_COST = 1.38
"""Growth cost of an image's bottom row relative to its top row, rising linearly in between: the
bands own equal shares of this cost, not of the rows (:func:`band_rows`). Cameras looking ahead
see near, textured, slanted ground in their lower rows, where the growth accepts more candidates:
of two bands of equal rows the lower one grew longer on every pair measured (Teddy 12.6 / 18.5
ms, Venus 9.9 / 13.0, KITTI 000045 44 / 91, the built-in scene 18.6 / 23.9). With this slope
two bands meet at 54 % of the rows, which cut the slower band's growth on 23 of 25 pairs
(Middlebury, KITTI, Aloe, synthetic scenes 0-16; by 6 % on average; ``docs/matching.md``)."""


def band_rows(h: int, n_bands: int, overlap: int) -> list[tuple[int, int, int, int]]:
    """Rows of each band: ``(own_lo, own_hi, grow_lo, grow_hi)``, half-open, in image rows.

    Bands own equal shares of the growth cost modelled by :data:`LOWER_ROWS_COST` (at least one
    row each; the lower bands are thinner) and grow over ``overlap`` more rows on each side,
    inside the image.

    Examples
    --------
    >>> band_rows(100, 2, 16)
    [(0, 54, 0, 70), (54, 100, 38, 100)]
    """
    if int(n_bands) != n_bands or n_bands < 1:
        raise InvalidInputError(f"n_bands: expected an integer >= 1, got {n_bands}")
    if int(overlap) != overlap or overlap < 0:
        raise InvalidInputError(f"overlap: expected an integer >= 0, got {overlap}")
    n = min(int(n_bands), h)
    # cost of rows [0, y), row y costing 1 + k (y / h - 1/2): y (1 - k/2) + k y^2 / (2 h); a band
    # ends where it reaches i / n of the whole (h), the root of that quadratic
    k = 2.0 * (LOWER_ROWS_COST - 1.0) / (LOWER_ROWS_COST + 1.0)
    a = 1.0 - k / 2.0
    edges = [0]
    for i in range(1, n + 1):
        cut = h * (math.sqrt(a * a + 2.0 * k * i / n) - a) / k if k else i * h / n
        edges.append(min(max(round(cut), edges[-1] + 1), h - (n - i)))  # at least one row per band
    return [(lo, hi, max(0, lo - overlap), min(h, hi + overlap)) for lo, hi in zip(edges[:-1], edges[1:])]


FINAL_PIECES = 4
"""Pieces of rows a band's final matching is cut into, of about equal candidate counts; a thread
that has finished its own band takes pieces of a band still matching (Teddy: the band grown last
matched in 2.6 ms alone; cut into equal row counts, its bottom piece held 1.9x the candidates of
its top one and took 2.8x the time)."""


_POLL_S = 0.05
"""A thread waiting for work wakes at least this often (seconds) to see whether another band has
failed or was interrupted (a ``KeyboardInterrupt`` may land where no notification follows)."""


class _SharedWork:
    """Work the band threads hand each other once their growth is done.

    Tasks are pieces of a band's final matching (owned by the band, which waits for them) and
    strips of the shifted-window check (:data:`~stereo_obstacles.shifted_windows.STRIPS_PER_THREAD`
    per band; a strip is handed out once every band owning one of its rows or of the ``RADIUS``
    rows around it has added its final matches). A thread waits for work only while a band is
    still running, so that a call whose bands run one after the other on one thread never waits.
    A band that fails (or is interrupted) calls :meth:`abort`: no thread waits any longer, and a
    band waiting for a piece that will not be run raises the first band's error.
    """

    def __init__(self, inputs: SimilarityInputs, bands: list[tuple[int, int, int, int]], *, check: bool,
                 greedy: bool) -> None:
        self.check = ShiftedWindowCheck(inputs) if check else None
        self._strips = []
        if check:
            for own_lo, own_hi, _, _ in bands:
                edges = [own_lo + round(i * (own_hi - own_lo) / STRIPS_PER_THREAD)
                         for i in range(STRIPS_PER_THREAD + 1)]
                for lo, hi in zip(edges[:-1], edges[1:]):
                    if hi > lo:
                        needs = {b for b, rows in enumerate(bands)
                                 if rows[0] < hi + RADIUS and rows[1] > lo - RADIUS}
                        self._strips.append((lo, hi, needs))
        self._own_rows = [(own_lo, own_hi) for own_lo, own_hi, _, _ in bands]
        self._hands_out = check or not greedy  # otherwise there is never anything to share
        self.state = ["waiting"] * len(bands)
        self._added = set()
        self._pending = []  # (owning band or None, task)
        self._error = None
        self.n_checked = 0
        self.last_check_end = 0.0
        self._changed = threading.Condition()

    def set_state(self, band: int, state: str) -> None:
        """Mark a band ``"running"`` (it may hand out more work) or ``"done"``."""
        with self._changed:
            self.state[band] = state
            self._changed.notify_all()

    def abort(self, error: BaseException) -> None:
        """A band failed with ``error``: stop every wait (plain assignments first: taking the lock
        may itself be interrupted, and waiting threads poll)."""
        if self._error is None:
            self._error = error
        with self._changed:
            self._changed.notify_all()

    def _take(self, owner):
        for k, (task_owner, task) in enumerate(self._pending):
            if owner is None or task_owner == owner:
                del self._pending[k]
                return task
        return None

    def _run_tasks(self, owner, more_may_come) -> None:
        """Run the pending tasks of band ``owner`` (of any band when None) until none is left and
        ``more_may_come()`` (called under the lock) is false, or a band has failed."""
        while True:
            with self._changed:
                task = self._take(owner)
                while task is None and more_may_come() and self._error is None:
                    self._changed.wait(_POLL_S)
                    task = self._take(owner)
            if task is None:
                return
            try:
                task()
            finally:
                with self._changed:
                    self._changed.notify_all()

    def final_matching(self, band: int, y, x, xr, c, shape, rows, margin: float,
                       row_offset: int) -> tuple[np.ndarray, int]:
        """Winners of the stable matching of a band's candidates (band coordinates, image row =
        band row + ``row_offset``) in rows ``rows = (lo, hi)``, as indices into the candidates in
        row order, and the number of candidates in those rows. The rows are matched in
        :data:`FINAL_PIECES` pieces that idle threads may take, each adding its winners to the
        check; the calling thread runs the pieces nobody took and waits for the others."""
        matching = RowMatching(y, x, xr, c, shape, margin=margin)
        lo, hi = rows
        edges = matching.row_cuts(lo, hi, FINAL_PIECES)
        outcome = [None] * FINAL_PIECES  # the piece's winners, or the error it raised (raised here)

        def piece(k):
            try:
                won = matching.match_rows(edges[k], edges[k + 1])
                if self.check is not None:
                    self.check.add_from_table(y, x, xr, won, row_offset)
                outcome[k] = won
            except BaseException as error:
                outcome[k] = error
                if not isinstance(error, Exception):
                    raise  # an interrupt also stops the thread it landed on

        with self._changed:
            self._pending.extend((band, lambda k=k: piece(k)) for k in range(FINAL_PIECES))
            self._changed.notify_all()
        self._run_tasks(band, lambda: any(result is None for result in outcome))
        for result in outcome:
            if isinstance(result, BaseException):
                raise result
        if any(result is None for result in outcome):
            raise self._error  # a piece another thread took was never run: that thread failed
        if self.check is not None:
            self.added(band)
        return np.concatenate(outcome), matching.n_candidates(lo, hi)

    def added(self, band: int) -> None:
        """Note that every final match of a band is in the check, and hand out the strips that
        became ready."""
        self.check.count_jumps(*self._own_rows[band])
        with self._changed:
            self._added.add(band)
            ready = [strip for strip in self._strips if strip[2] <= self._added]
            self._strips = [strip for strip in self._strips if not strip[2] <= self._added]
            # the strips with the most disparity jumps first, so that a heavy strip does not come
            # last (Teddy's bottom strip, 1.05 ms, was its last: the other thread sat idle meanwhile)
            ready.sort(key=lambda strip: -self.check.jumps_near(strip[0], strip[1]))
            self._pending.extend((None, lambda lo=lo, hi=hi: self._check(lo, hi)) for lo, hi, _ in ready)
            self._changed.notify_all()

    def _check(self, lo: int, hi: int) -> None:
        n = self.check.check_rows(lo, hi)
        with self._changed:
            self.n_checked += n
            self.last_check_end = max(self.last_check_end, time.perf_counter())

    def help_others(self) -> None:
        """Run the work any band hands out, waiting for more while a band that may hand some out
        is still running."""
        self._run_tasks(None, lambda: self._hands_out and "running" in self.state)


def _match_band(inputs, seeds, scanned_hi, band, rows, options, work, t_start):
    """Grow one band, match its own rows, hand the matches to the check; returns arrays in
    image rows, counters and stage end times."""
    own_lo, own_hi, lo, hi = rows
    try:
        work.set_state(band, "running")
        inside = (seeds.y >= lo) & (seeds.y < hi)
        band_seeds = Seeds(seeds.y[inside] - lo, seeds.x[inside], seeds.x_right[inside], seeds.similarity[inside],
                           0, 0)
        growth = grow(inputs.rows(lo, hi), band_seeds, scanned_hi=scanned_hi[lo:hi], **options["grow"])
        t_grown = time.perf_counter() - t_start
        table = (growth.y, growth.x, growth.x_right, growth.similarity)
        own_rows = (own_lo - lo, own_hi - lo)
        if options["greedy"]:
            kept = np.flatnonzero((growth.y >= own_rows[0]) & (growth.y < own_rows[1]))
            n_own = kept.size
        else:
            kept, n_own = work.final_matching(band, *table, (hi - lo, inputs.shape[1]), own_rows,
                                              options["final_margin"], lo)
        t_matched = time.perf_counter() - t_start
        # index lists and take(): a boolean mask that keeps ~60 % of the entries at random (the
        # winners) indexes several times slower, 0.8 ms per array on Teddy
        y, x, xr, c = (a.take(kept) for a in table)
        y_image = (y + lo).astype(np.int32)
        if work.check is not None and options["greedy"]:
            work.check.add(y_image, x, x - xr)
            work.added(band)
        work.set_state(band, "done")
        work.help_others()  # the band's own subpixel look-ups wait: they are not matching time
    except BaseException as error:
        work.abort(error)
        raise
    c_minus, c_plus = growth.side_similarities(y, x, x - xr)
    offset = parabola_offset(c_minus, c, c_plus)
    counts = (n_own, growth.n_computed, growth.n_rescanned, growth.n_overflow)
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
        Largest disparity a seed search evaluated per pixel (``seeds.NOT_SCANNED``: none), for the visited count.
    n_bands : int
        Bands (threads), >= 1; 1 is one growth over the whole image. When a band would hold no seed
        (a few user seeds), the image is grown as one band: the growth of a band starts only from
        the seeds in its rows and overlap.
    overlap : int
        Rows of each neighbour a band grows over, >= 0.
    d_min, d_max, tau, mu, max_candidates, margin_reference, greedy
        As :func:`stereo_obstacles.growing.grow`.
    final_margin : float
        Margin of :func:`stereo_obstacles.stable_matching.stable_matching` (ignored when greedy).
    shifted_windows : bool
        Run the shifted-window check (:class:`stereo_obstacles.shifted_windows.ShiftedWindowCheck`,
        strip by strip) and drop the matches it rejects.

    Returns
    -------
    BandedMatch
    """
    h = inputs.shape[0]
    if scanned_hi.shape != inputs.shape:
        raise InvalidInputError(f"scanned_hi: expected shape {inputs.shape}, got {scanned_hi.shape}")
    bands = band_rows(h, n_bands, overlap)
    if len(bands) > 1 and not all(np.any((seeds.y >= lo) & (seeds.y < hi)) for _, _, lo, hi in bands):
        bands = band_rows(h, 1, overlap)  # a band without a seed would grow nothing: one growth instead
    options = {"grow": dict(d_min=d_min, d_max=d_max, tau=tau, mu=mu, max_candidates=max_candidates,
                            margin_reference=margin_reference, greedy=greedy),
               "greedy": greedy, "final_margin": final_margin}
    work = _SharedWork(inputs, bands, check=bool(shifted_windows), greedy=bool(greedy))
    t_start = time.perf_counter()
    parts = run_in_threads(_match_band, [(inputs, seeds, scanned_hi, band, rows, options, work, t_start)
                                         for band, rows in enumerate(bands)])
    y, x, xr, c, offset = (np.concatenate([p[k] for p in parts]) for k in range(5))
    counts = [int(v) for v in np.sum([p[5] for p in parts], axis=0)]
    matched_seconds = max(p[7] for p in parts)
    n_checked = n_rejected = 0
    checked_seconds = matched_seconds
    if work.check is not None:
        keep = work.check.keep(y, x)
        n_checked, n_rejected = work.n_checked, int(keep.size - np.count_nonzero(keep))
        checked_seconds = max(work.last_check_end - t_start, matched_seconds)
        if n_rejected:
            kept = np.flatnonzero(keep)
            y, x, xr, c, offset = (a.take(kept) for a in (y, x, xr, c, offset))
    return BandedMatch(y, x, xr, c, offset, *counts, n_checked, n_rejected, max(p[6] for p in parts),
                       matched_seconds, checked_seconds)
