"""Least-squares planes ``d = a x + b y + c`` through pixels and their disparities.

A surface that is flat in the scene is a plane in this form: with rectified cameras the
disparity ``f B / Z`` of a scene plane is linear in the image coordinates. The fit needs only
the sums of :func:`plane_moments`, which add up over any union of pixel sets: a plane
through two groups of pixels costs no pass over their pixels once each group's sums are known.
No BLAS call is made: NumPy's (``@``, ``dot``) threads even small products, and its threads
spin against the matcher's (``docs/pipeline.md``, "Speed").
"""

from __future__ import annotations

import numpy as np

from stereo_obstacles.quantiles import MAD_TO_SIGMA, median


def plane_moments(xs: np.ndarray, ys: np.ndarray, ds: np.ndarray) -> np.ndarray:
    """``float64 (10,)``: the sums of 1, x, y, d, x x, x y, y y, x d, y d and d d over the points.

    Parameters
    ----------
    xs, ys
        1-D pixel columns and rows.
    ds
        1-D values at them (disparities in pixels), the same length.
    """
    x, y, d = (np.asarray(v, dtype=np.float64) for v in (xs, ys, ds))
    return np.array([x.size, x.sum(), y.sum(), d.sum(), (x * x).sum(), (x * y).sum(), (y * y).sum(),
                     (x * d).sum(), (y * d).sum(), (d * d).sum()])


def plane_from_moments(moments: np.ndarray) -> tuple[float, float, float] | None:
    """``(a, b, c)`` minimising ``sum (a x + b y + c - d)**2`` over the points whose
    :func:`plane_moments` these are, or None when they do not pin a plane down (no points, or all
    in one row, one column or one line). Centred 2 x 2 normal equations, written out."""
    n, sx, sy, sd, sxx, sxy, syy, sxd, syd = (float(m) for m in moments[:9])
    if n <= 0:
        return None
    mx, my, md = sx / n, sy / n, sd / n
    cxx, cyy, cxy = sxx / n - mx * mx, syy / n - my * my, sxy / n - mx * my
    det = cxx * cyy - cxy * cxy
    if cxx <= 0 or cyy <= 0 or det <= 1e-6 * cxx * cyy:
        return None
    cxd, cyd = sxd / n - mx * md, syd / n - my * md
    a = (cxd * cyy - cyd * cxy) / det
    b = (cyd * cxx - cxd * cxy) / det
    return a, b, md - a * mx - b * my


def least_squares_plane(xs: np.ndarray, ys: np.ndarray, ds: np.ndarray) -> tuple[float, float, float] | None:
    """:func:`plane_from_moments` of the points ``(xs, ys)`` with values ``ds`` (1-D, one length)."""
    return plane_from_moments(plane_moments(xs, ys, ds))


def mean_squared_residual(moments: np.ndarray, plane: tuple[float, float, float]) -> float:
    """Mean of ``(d - (a x + b y + c))**2`` over the points whose :func:`plane_moments` these are
    (NaN for none; never below 0)."""
    n, sx, sy, sd, sxx, sxy, syy, sxd, syd, sdd = (float(m) for m in moments)
    a, b, c = plane
    if n <= 0:
        return float("nan")
    total = (sdd - 2 * (a * sxd + b * syd + c * sd) + a * a * sxx + 2 * a * b * sxy + b * b * syy
             + 2 * c * (a * sx + b * sy) + c * c * n)
    return max(total / n, 0.0)


def plane_at(plane: tuple[float, float, float], xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """The plane's value ``a x + b y + c`` (pixels of disparity) at columns ``xs`` and rows ``ys``."""
    a, b, c = plane
    return a * xs + b * ys + c


ROBUST_ROUNDS, ROBUST_SAMPLE = 3, 4000
""":func:`robust_plane` refits this many times, on at most this many points (evenly spaced)."""
ROBUST_FLOOR_PX, ROBUST_DEVIATIONS = 0.3, 2.5
"""Each refit drops the points farther from the previous plane than ``max(ROBUST_FLOOR_PX,
ROBUST_DEVIATIONS`` robust standard deviations of the kept points' residuals)."""
MIN_ROBUST_POINTS = 30
"""A robust plane needs this many points kept."""


def robust_plane(xs: np.ndarray, ys: np.ndarray, ds: np.ndarray) -> tuple[float, float, float] | None:
    """Least-squares plane of the points, refitted without the ones off it (a tenth of wild
    matches does not tilt it); None when fewer than ``MIN_ROBUST_POINTS`` stay or they do not pin
    a plane down. ``xs, ys, ds`` as for :func:`plane_moments`. The residuals' spread is their
    median absolute value: a start tilted by more than about a third of outliers is not
    recovered."""
    every = -(-len(ds) // ROBUST_SAMPLE)
    xs, ys, ds = (np.asarray(v, dtype=np.float64)[::every] for v in (xs, ys, ds))
    kept = np.ones(len(ds), dtype=bool)
    for _ in range(ROBUST_ROUNDS):
        plane = least_squares_plane(xs[kept], ys[kept], ds[kept])
        if plane is None:
            return None
        residual = np.abs(ds - plane_at(plane, xs, ys))
        kept = residual <= max(ROBUST_FLOOR_PX, ROBUST_DEVIATIONS * MAD_TO_SIGMA * median(residual[kept]))
        if np.count_nonzero(kept) < MIN_ROBUST_POINTS:
            return None
    return least_squares_plane(xs[kept], ys[kept], ds[kept])
