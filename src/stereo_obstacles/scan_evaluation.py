"""How well the free range per direction agrees with the synthetic world's truth.

The true range of a sector of the detection's scan (:mod:`stereo_obstacles.direction_scan`) is the
smallest horizontal range over the pixels of true obstacles at least ``min_height_m`` high that
both cameras see (the renderer's ``nonocc``), counting an obstacle there when it has at least
the scan's ``min_pixels`` such pixels in the sector: what a stereo method could range by the
scan's own rule. Each sector
whose true range lies within ``max_distance_m`` is scored:

* found, when the scan has a range there, with its relative error;
* *overstated* when the scan has no range there or one more than ``TOLERANCE_PCT`` farther than
  the truth: it promises free space that is not there, the error that matters for safety.

A sector is *understated* when the scan's range lies within ``max_distance_m`` and more than
``TOLERANCE_PCT`` nearer than every true obstacle pixel the left camera sees there (of any
height, or none there): free space withheld, mostly beside an object whose outline the window
matching widened into the next sector.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.direction_scan import DirectionScan, direction_scan
from stereo_obstacles.errors import InvalidInputError

TOLERANCE_PCT = 5.0
"""A sector's range is overstated or understated when it is off the truth by more than this (per cent)."""


@dataclass(frozen=True)
class ScanComparison:
    """One scene's scan beside its truth, one value per sector (metres; ``None``: none there)."""

    reported_m: tuple[float | None, ...]
    true_m: tuple[float | None, ...]
    """Nearest range of the tall obstacles seen by both cameras (the scored truth)."""
    nearest_seen_m: tuple[float | None, ...]
    """Nearest range of any obstacle pixel the left camera sees (for the understated sectors)."""


@dataclass(frozen=True)
class ScanSummary:
    """Figures over many scenes' sectors whose true range lies within ``max_distance_m``."""

    n_sectors: int
    n_with_obstacle: int
    n_reported: int
    median_abs_error_pct: float | None
    p95_abs_error_pct: float | None
    within_tolerance: float | None
    """Fraction of the reported ones within ``TOLERANCE_PCT`` of the truth."""
    n_overstated: int
    n_understated: int

    def to_dict(self) -> dict:
        """JSON-ready mapping."""
        return asdict(self)


def compare_scan_with_truth(scan: DirectionScan, instances: np.ndarray, true_disparity: np.ndarray,
                            seen_by_both: np.ndarray, truths, calibration: StereoCalibration, *,
                            min_height_m: float, min_pixels: int) -> ScanComparison:
    """Truth per sector of ``scan`` (module docstring).

    Parameters
    ----------
    scan
        The detection's scan.
    instances
        ``uint8 (H, W)`` true obstacle id per left pixel, 0 for none.
    true_disparity
        ``float32 (H, W)`` exact disparity of each left pixel, pixels.
    seen_by_both
        ``(H, W)``, non-zero where the right camera sees the left pixel too.
    truths
        The true obstacles (``stereo_obstacles.synthetic.ObstacleTruth``), for their heights.
    calibration
        The calibration the scan was measured with.
    min_height_m
        True obstacles lower than this are not scored (they still count for understated sectors).
    min_pixels
        Pixels a true obstacle needs in a sector to count there (the scan's ``min_pixels``).

    Returns
    -------
    ScanComparison

    Raises
    ------
    InvalidInputError
        Maps of other shapes, or a scan of other sectors than these images give.
    """
    instances = np.asarray(instances)
    if np.shape(true_disparity) != instances.shape or np.shape(seen_by_both) != instances.shape:
        raise InvalidInputError(f"instances {instances.shape}, true_disparity {np.shape(true_disparity)} and "
                                f"seen_by_both {np.shape(seen_by_both)} must have one shape")
    tall = [t.obstacle_id for t in truths if t.size_m[2] >= min_height_m]
    scored = np.where(np.isin(instances, tall) & np.asarray(seen_by_both, dtype=bool), instances, 0)

    def nearest(ids: np.ndarray, pixels: int) -> tuple[float | None, ...]:
        truth = direction_scan(ids, true_disparity, calibration, sector_deg=scan.sector_deg, min_pixels=pixels,
                               percentile=0.0)
        if truth.first_bearing_deg != scan.first_bearing_deg or len(truth.ranges_m) != len(scan.ranges_m):
            raise InvalidInputError("the scan was not measured on these images with this calibration")
        return truth.ranges_m

    return ScanComparison(reported_m=scan.ranges_m, true_m=nearest(scored, min_pixels),
                          nearest_seen_m=nearest(instances, 1))


def summarise_scans(comparisons: list[ScanComparison], *, max_distance_m: float) -> ScanSummary:
    """Pool the sectors of many scenes (module docstring); sectors whose true range lies beyond
    ``max_distance_m`` (metres) are not scored."""
    def values(name: str) -> np.ndarray:
        return np.array([math.inf if v is None else v for c in comparisons for v in getattr(c, name)], dtype=float)

    reported, true, seen = values("reported_m"), values("true_m"), values("nearest_seen_m")
    scored = true <= max_distance_m
    found = scored & np.isfinite(reported)
    errors = 100 * np.abs(reported[found] - true[found]) / true[found]
    off = TOLERANCE_PCT / 100
    return ScanSummary(
        n_sectors=int(reported.size), n_with_obstacle=int(scored.sum()), n_reported=int(found.sum()),
        median_abs_error_pct=float(np.median(errors)) if errors.size else None,
        p95_abs_error_pct=float(np.percentile(errors, 95)) if errors.size else None,
        within_tolerance=float(np.mean(errors <= TOLERANCE_PCT)) if errors.size else None,
        n_overstated=int(np.count_nonzero(scored & (reported > true * (1 + off)))),     # none: inf
        n_understated=int(np.count_nonzero((reported <= max_distance_m) & (reported < seen * (1 - off)))))


__all__ = ["TOLERANCE_PCT", "ScanComparison", "ScanSummary", "compare_scan_with_truth", "summarise_scans"]
