"""Accuracy of a disparity map against ground truth: density, bad-N, end-point error, KITTI D1.

Definitions (all disparities in pixels, NaN = no value):

* **evaluated pixels**: ground truth is finite and, when a mask is given, the mask is true
  (the Middlebury "nonocc" region: non-occluded pixels with ground truth);
* **matched pixels**: evaluated pixels where the estimate is finite;
* **density** = matched / evaluated;
* **bad-N over matched** = share of matched pixels with ``|d - gt| > N`` (the figure a
  semi-dense matcher is judged by: how often the pixels it does claim are wrong);
* **bad-N counting unmatched** = (matched with ``|d - gt| > N`` + unmatched) / evaluated
  (the figure a dense matcher is judged by: an unmatched pixel is as useless as a wrong one);
* **EPE** = mean ``|d - gt|`` over matched pixels;
* **D1** (KITTI 2015) = share with ``|d - gt| > 3`` px **and** ``|d - gt| > 5 %`` of ``gt``,
  over matched pixels and counting unmatched as bad.

Percentages are in percent (0..100). A figure that is undefined (no matched pixel) is NaN,
written as ``null`` by :meth:`DisparityMetrics.to_dict`.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from stereo_obstacles.errors import ImageMismatchError, InvalidInputError
from stereo_obstacles.float_maps import check_float_map

D1_ABSOLUTE_PX = 3.0
"""KITTI D1: an error must exceed this many pixels ..."""

D1_RELATIVE = 0.05
"""... and this fraction of the true disparity to count as bad."""


@dataclass(frozen=True)
class DisparityMetrics:
    """Accuracy figures of one disparity map (see the module docstring for definitions).

    Attributes
    ----------
    evaluated_px : int
        Pixels with ground truth inside the evaluation mask.
    matched_px : int
        Evaluated pixels that have an estimated disparity.
    density_pct : float
        ``100 * matched_px / evaluated_px``.
    bad1_matched_pct, bad2_matched_pct : float
        Percent of matched pixels with an error above 1 px (2 px); NaN without matches.
    bad1_all_pct, bad2_all_pct : float
        Percent of evaluated pixels that are unmatched or off by more than 1 px (2 px).
    epe_px : float
        Mean absolute error over matched pixels, pixels; NaN without matches.
    d1_matched_pct, d1_all_pct : float
        KITTI D1 over matched pixels, and counting unmatched pixels as bad.
    """

    evaluated_px: int
    matched_px: int
    density_pct: float
    bad1_matched_pct: float
    bad2_matched_pct: float
    bad1_all_pct: float
    bad2_all_pct: float
    epe_px: float
    d1_matched_pct: float
    d1_all_pct: float

    def __post_init__(self) -> None:
        if self.evaluated_px <= 0:
            raise InvalidInputError(f"evaluated_px must be > 0, got {self.evaluated_px}")
        if not 0 <= self.matched_px <= self.evaluated_px:
            raise InvalidInputError(f"matched_px must be in [0, {self.evaluated_px}], "
                                    f"got {self.matched_px}")
        for name in ("density_pct", "bad1_matched_pct", "bad2_matched_pct", "bad1_all_pct",
                     "bad2_all_pct", "d1_matched_pct", "d1_all_pct"):
            value = getattr(self, name)
            if not (math.isnan(value) or 0.0 <= value <= 100.0):
                raise InvalidInputError(f"{name} must be a percentage in [0, 100], got {value}")
        if not (math.isnan(self.epe_px) or self.epe_px >= 0.0):
            raise InvalidInputError(f"epe_px must be >= 0, got {self.epe_px}")

    def to_dict(self) -> dict:
        """JSON-ready mapping; undefined (NaN) figures become ``None``."""
        return {k: (None if isinstance(v, float) and math.isnan(v) else v)
                for k, v in asdict(self).items()}


def _percent(count: int, total: int) -> float:
    return 100.0 * count / total if total else math.nan


def evaluate_disparity(disparity: np.ndarray, gt_disparity: np.ndarray, *,
                       mask: np.ndarray | None = None) -> DisparityMetrics:
    """Compare an estimated disparity map with ground truth.

    Parameters
    ----------
    disparity : numpy.ndarray
        Estimate, float ``(H, W)`` in pixels, NaN (or any non-finite value) where unmatched.
    gt_disparity : numpy.ndarray
        Ground truth, float ``(H, W)`` in pixels, NaN where unknown.
    mask : numpy.ndarray, optional
        Boolean ``(H, W)`` evaluation region (for example the non-occluded mask); pixels
        outside it are ignored. Default: every pixel with ground truth.

    Returns
    -------
    DisparityMetrics

    Raises
    ------
    InvalidInputError
        Arrays that are not 2-D floats, a non-boolean mask, or no pixel to evaluate.
    ImageMismatchError
        The three arrays differ in shape.

    Examples
    --------
    >>> import numpy as np
    >>> gt = np.full((2, 2), 10.0, dtype=np.float32)
    >>> d = np.array([[10.2, 12.5], [np.nan, 10.0]], dtype=np.float32)
    >>> m = evaluate_disparity(d, gt)
    >>> round(m.density_pct, 1), round(m.bad1_matched_pct, 1), round(m.bad1_all_pct, 1)
    (75.0, 33.3, 50.0)
    """
    est = check_float_map(disparity, "disparity")
    gt = check_float_map(gt_disparity, "gt_disparity")
    if est.shape != gt.shape:
        raise ImageMismatchError(f"disparity has shape {est.shape} but gt_disparity has {gt.shape}")
    evaluated = np.isfinite(gt)
    if mask is not None:
        m = np.asarray(mask)
        if m.dtype != np.bool_:
            raise InvalidInputError(f"mask must be a boolean array, got {m.dtype}")
        if m.shape != gt.shape:
            raise ImageMismatchError(f"mask has shape {m.shape} but gt_disparity has {gt.shape}")
        evaluated &= m
    n_eval = int(evaluated.sum())
    if n_eval == 0:
        raise InvalidInputError("no pixel to evaluate: the ground truth is empty inside the mask")
    matched = evaluated & np.isfinite(est)
    n_matched = int(matched.sum())
    truth = gt[matched].astype(np.float64)
    error = np.abs(est[matched].astype(np.float64) - truth)
    bad1 = int((error > 1.0).sum())
    bad2 = int((error > 2.0).sum())
    d1 = int(((error > D1_ABSOLUTE_PX) & (error > D1_RELATIVE * np.abs(truth))).sum())
    unmatched = n_eval - n_matched
    return DisparityMetrics(
        evaluated_px=n_eval,
        matched_px=n_matched,
        density_pct=_percent(n_matched, n_eval),
        bad1_matched_pct=_percent(bad1, n_matched),
        bad2_matched_pct=_percent(bad2, n_matched),
        bad1_all_pct=_percent(bad1 + unmatched, n_eval),
        bad2_all_pct=_percent(bad2 + unmatched, n_eval),
        epe_px=float(error.mean()) if n_matched else math.nan,
        d1_matched_pct=_percent(d1, n_matched),
        d1_all_pct=_percent(d1 + unmatched, n_eval),
    )


__all__ = ["D1_ABSOLUTE_PX", "D1_RELATIVE", "DisparityMetrics", "evaluate_disparity"]
