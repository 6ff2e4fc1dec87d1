"""Matching on a reduced copy of the pair, with the disparity brought back to full resolution.

The cost of :func:`stereo_obstacles.matching.match` grows with the number of pixels (and the
disparity range with the width), so matching a pair shrunk by ``scale`` costs about
``scale ** 2`` as much. The disparity found at the reduced size is divided by the horizontal
scale and spread back over the full-size pixels (nearest neighbour: unmatched stays NaN, no
value is invented between a foreground and a background). The price is resolution: a
disparity error of ``e`` pixels at the reduced size is ``e / scale`` at full size, and thin
objects lose their pixels first (measured in ``docs/pipeline.md``, "Matching scale").
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.matching import MatchResult, match

__all__ = ["check_scale", "match_at_scale", "scaled_size"]


def check_scale(scale: float) -> float:
    """``scale`` as a float in ``(0, 1]``, or :class:`InvalidInputError`."""
    if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not math.isfinite(scale) \
            or not 0.0 < scale <= 1.0:
        raise InvalidInputError(f"matching scale must be in (0, 1], got {scale!r}")
    return float(scale)


def scaled_size(width: int, height: int, scale: float) -> tuple[int, int]:
    """``(width, height)`` of the reduced copy: each side times ``scale``, rounded, at least 1."""
    return max(1, round(width * scale)), max(1, round(height * scale))


def _scaled_seed_points(points: np.ndarray, sx: float, sy: float, width: int, height: int,
                        max_disparity: int | None) -> np.ndarray:
    """Seeds ``(x, y, d)`` of the full-size image moved to the reduced one (integer pixels); those that fall
    outside it or its disparity range are dropped (a seed is a hint, not a constraint)."""
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise InvalidInputError(f"seed_points: expected shape (N, 3) of (x, y, d), got {p.shape}")
    # the reduced pixel whose area holds the full-size pixel's centre
    x, y, d = np.floor((p[:, 0] + 0.5) * sx), np.floor((p[:, 1] + 0.5) * sy), np.rint(p[:, 2] * sx)
    keep = np.isfinite(x) & np.isfinite(y) & np.isfinite(d) & (x >= 0) & (x < width) & (y >= 0) & (y < height) \
        & (d >= 0) & (x - d >= 0)
    if max_disparity is not None:
        keep &= d <= max_disparity
    return np.stack([x[keep], y[keep], d[keep]], axis=1)


def match_at_scale(left: np.ndarray, right: np.ndarray, scale: float, *, seed_points: np.ndarray | None = None,
                   max_disparity: int | None = None, **options) -> tuple[np.ndarray, MatchResult]:
    """Match ``left`` and ``right`` shrunk by ``scale``; return the full-size disparity and the match.

    Parameters
    ----------
    left, right : ndarray, shape (H, W) or (H, W, 3)
        The rectified pair at full size.
    scale : float
        In ``(0, 1]``; 1 matches the pair as it is.
    seed_points : ndarray, shape (N, 3), optional
        Seeds ``(x, y, d)`` in full-size pixels (e.g. the previous frame's matches).
    max_disparity : int, optional
        Largest disparity in full-size pixels.
    **options
        Other keyword arguments of :func:`stereo_obstacles.matching.match`.

    Returns
    -------
    disparity : ndarray of float32, shape (H, W)
        Full-size left disparity in full-size pixels, NaN where unmatched.
    result : MatchResult
        The match at the reduced size (its statistics count reduced pixels).
    """
    scale = check_scale(scale)
    h, w = left.shape[:2]
    if scale == 1.0:
        result = match(left, right, seed_points=seed_points, max_disparity=max_disparity, **options)
        return result.disparity, result
    small_w, small_h = scaled_size(w, h, scale)
    sx, sy = small_w / w, small_h / h
    small_max = None if max_disparity is None else max(0, math.ceil(max_disparity * sx))
    small_seeds = (None if seed_points is None
                   else _scaled_seed_points(seed_points, sx, sy, small_w, small_h, small_max))
    shrink = [cv2.resize(image, (small_w, small_h), interpolation=cv2.INTER_AREA) for image in (left, right)]
    result = match(shrink[0], shrink[1], seed_points=small_seeds, max_disparity=small_max, **options)
    disparity = cv2.resize(result.disparity / np.float32(sx), (w, h), interpolation=cv2.INTER_NEAREST)
    return disparity, result
