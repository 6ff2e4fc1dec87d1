"""Coarse-to-fine matching: GCS on a reduced copy of the pair, refined on the full-size images.

The cost of :func:`stereo_obstacles.matching.match` grows with the number of pixels (and the
disparity range with the width), so matching a pair shrunk by ``scale`` costs about
``scale ** 2`` as much. The disparity found at the reduced size is divided by the horizontal
scale and spread back over the full-size pixels (nearest neighbour: unmatched stays NaN, no
value is invented between a foreground and a background); each of those pixels is then
matched again on the full-size images within a few pixels of that estimate
(:mod:`stereo_obstacles.refinement`) and, as in ``match``, checked by the shifted windows near
disparity jumps. The refinement brings the precision back to full-size pixels; what the reduced
size loses for good is thin structures and the pixels next to unmatched areas (measured in
``docs/matching.md``, "Coarse to fine", and ``docs/pipeline.md``, "Matching scale").
"""

from __future__ import annotations

import inspect
import logging
import math
import time

import cv2
import numpy as np

from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.matching import MatchResult, MatchStats, disparity_range, match
from stereo_obstacles.refinement import refine_disparity
from stereo_obstacles.shifted_windows import shifted_window_check_map
from stereo_obstacles.similarity import grey_pair, prepare_similarity

__all__ = ["MIN_REDUCED_SIDE", "check_scale", "effective_scale", "match_at_scale", "refine_at_full_size",
           "scaled_size", "warn_if_scale_raised"]

logger = logging.getLogger(__name__)

MIN_REDUCED_SIDE = 120
"""A pair is never shrunk below this many rows or columns: smaller images are matched at a larger
scale (at full size when a side is 120 pixels or shorter), where a 5 x 5 window and 8-pixel seed
cells still see enough texture."""


def check_scale(scale: float) -> float:
    """``scale`` as a float in ``(0, 1]``, or :class:`InvalidInputError`."""
    if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not math.isfinite(scale) \
            or not 0.0 < scale <= 1.0:
        raise InvalidInputError(f"matching scale must be in (0, 1], got {scale!r}")
    return float(scale)


def effective_scale(height: int, width: int, scale: float) -> float:
    """The scale :func:`match_at_scale` uses for images of ``height`` x ``width`` pixels: ``scale``,
    raised so that the reduced copy keeps :data:`MIN_REDUCED_SIDE` rows and columns, and at most 1.

    Examples
    --------
    >>> effective_scale(480, 640, 0.5), effective_scale(200, 640, 0.5), effective_scale(400, 8, 0.5)
    (0.5, 0.6, 1.0)
    """
    return min(1.0, max(check_scale(scale), MIN_REDUCED_SIDE / min(height, width)))


def warn_if_scale_raised(height: int, width: int, scale: float) -> None:
    """Log a warning when images of ``height`` x ``width`` pixels are matched at a larger scale than
    ``scale`` (:func:`effective_scale`)."""
    used = effective_scale(height, width, scale)
    if used != scale:
        logger.warning("matching scale %g is raised to %.3g for these %dx%d images: the reduced copy keeps at "
                       "least %d pixels a side", scale, used, width, height, MIN_REDUCED_SIDE)


def scaled_size(width: int, height: int, scale: float) -> tuple[int, int]:
    """``(width, height)`` of the reduced copy: each side times ``scale``, rounded, at least 1."""
    return max(1, round(width * scale)), max(1, round(height * scale))


def _scaled_seed_points(points: np.ndarray, sx: float, sy: float, width: int, height: int,
                        d_range: tuple[int, int]) -> np.ndarray:
    """Seeds ``(x, y, d)`` of the full-size image moved to the reduced one (integer pixels); those that fall
    outside it or its inclusive disparity range ``d_range`` are dropped (a seed is a hint, not a
    constraint: one at the full-size range's end can round past the reduced range's)."""
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise InvalidInputError(f"seed_points: expected shape (N, 3) of (x, y, d), got {p.shape}")
    # the reduced pixel whose area holds the full-size pixel's centre
    x, y, d = np.floor((p[:, 0] + 0.5) * sx), np.floor((p[:, 1] + 0.5) * sy), np.rint(p[:, 2] * sx)
    keep = np.isfinite(x) & np.isfinite(y) & np.isfinite(d) & (x >= 0) & (x < width) & (y >= 0) & (y < height) \
        & (d >= d_range[0]) & (d <= d_range[1]) & (x - d >= 0)
    return np.stack([x[keep], y[keep], d[keep]], axis=1)


def _match_option(options: dict, name: str):
    """``options[name]``, or :func:`~stereo_obstacles.matching.match`'s default for it."""
    return options.get(name, inspect.signature(match).parameters[name].default)


def refine_at_full_size(left: np.ndarray, right: np.ndarray, estimate: np.ndarray, *,
                        max_disparity: int | None = None, **options) -> MatchResult:
    """The fine step: ``estimate`` (full-size pixels, NaN: none) matched again on the full-size pair.

    ``options`` are those of :func:`~stereo_obstacles.matching.match`; its ``tau``, ``similarity``,
    ``min_std``, ``min_disparity``, ``bands`` (threads) and ``shifted_windows`` apply here too.
    Returns a full-size :class:`~stereo_obstacles.matching.MatchResult` whose statistics are the
    refinement's: no seeds, growth or candidates; ``n_visited`` the similarities the refinement
    computed; ``match_seconds`` the refinement and the check.
    """
    t0 = time.perf_counter()
    h, w = left.shape[:2]
    d_min, d_max = disparity_range(w, _match_option(options, "min_disparity"), max_disparity)
    n_threads = int(_match_option(options, "bands"))
    inputs = prepare_similarity(*grey_pair(left, right),
                                kind=_match_option(options, "similarity"), min_std=_match_option(options, "min_std"),
                                n_threads=n_threads)
    t1 = time.perf_counter()
    refined = refine_disparity(inputs, estimate, tau=_match_option(options, "tau"), d_min=d_min, d_max=d_max,
                               n_threads=n_threads)
    t2 = time.perf_counter()
    disparity, similarity = refined.disparity, refined.similarity
    n_checked = n_rejected = 0
    if _match_option(options, "shifted_windows"):
        rejected, n_checked = shifted_window_check_map(inputs, refined.integer_disparity, n_threads=n_threads)
        disparity[rejected] = np.nan
        similarity[rejected] = np.nan
        n_rejected = int(np.count_nonzero(rejected))
    t3 = time.perf_counter()
    n_range = d_max - d_min + 1
    stats = MatchStats(
        n_seeds=0, n_seed_pixels=0, n_candidates=0, n_visited=refined.n_computed, n_memo_overflow=0,
        visited_fraction_full=refined.n_computed / (w * w * h),
        visited_fraction_range=refined.n_computed / (w * h * n_range),
        density=float(np.count_nonzero(np.isfinite(disparity))) / (w * h), d_min=d_min, d_max=d_max,
        prepare_seconds=t1 - t0, seeds_seconds=0.0, growth_seconds=0.0, final_seconds=0.0, subpixel_seconds=0.0,
        match_seconds=t3 - t1, total_seconds=t3 - t0, n_edge_checked=n_checked, n_edge_rejected=n_rejected,
        edge_check_seconds=t3 - t2)
    return MatchResult(disparity, similarity, stats)


def match_at_scale(left: np.ndarray, right: np.ndarray, scale: float, *, seed_points: np.ndarray | None = None,
                   max_disparity: int | None = None, **options) -> tuple[np.ndarray, MatchResult]:
    """Match ``left`` and ``right`` shrunk by ``scale``, refine at full size; return both results.

    Parameters
    ----------
    left, right : ndarray, shape (H, W) or (H, W, 3)
        The rectified pair at full size.
    scale : float
        In ``(0, 1]``; 1 matches the pair as it is (no refinement). Raised for small images
        (:func:`effective_scale`).
    seed_points : ndarray, shape (N, 3), optional
        Seeds ``(x, y, d)`` in full-size pixels (e.g. the previous frame's matches).
    max_disparity : int, optional
        Largest disparity in full-size pixels.
    **options
        Other keyword arguments of :func:`stereo_obstacles.matching.match`: all of them apply to
        the reduced-size match; those :func:`refine_at_full_size` takes apply at full size too
        (speckles, for example, are removed from the reduced-size match only).

    Returns
    -------
    disparity : ndarray of float32, shape (H, W)
        Full-size left disparity in full-size pixels, NaN where unmatched.
    result : MatchResult
        The match at the reduced size (its statistics count reduced pixels).
    """
    h, w = left.shape[:2]
    scale = effective_scale(h, w, scale)
    if scale == 1.0:
        result = match(left, right, seed_points=seed_points, max_disparity=max_disparity, **options)
        return result.disparity, result
    small_w, small_h = scaled_size(w, h, scale)
    sx, sy = small_w / w, small_h / h
    small_max = None if max_disparity is None else max(0, math.ceil(max_disparity * sx))
    small_options = dict(options, min_disparity=math.floor(_match_option(options, "min_disparity") * sx))
    small_seeds = (None if seed_points is None else _scaled_seed_points(
        seed_points, sx, sy, small_w, small_h, disparity_range(small_w, small_options["min_disparity"], small_max)))
    shrink = [cv2.resize(image, (small_w, small_h), interpolation=cv2.INTER_AREA) for image in (left, right)]
    result = match(shrink[0], shrink[1], seed_points=small_seeds, max_disparity=small_max, **small_options)
    estimate = cv2.resize(result.disparity / np.float32(sx), (w, h), interpolation=cv2.INTER_NEAREST)
    return refine_at_full_size(left, right, estimate, max_disparity=max_disparity, **options).disparity, result
