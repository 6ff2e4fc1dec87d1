"""How well depth from our disparity agrees with depth from a ground-truth disparity.

Both depths come from the same calibration (``Z = f B / (d + doffs)``), so the comparison
measures the matcher, not the calibration: relative error ``|Z - Z_gt| / Z_gt`` over the pixels
that have both a disparity and a ground truth (and lie in an optional mask, e.g. obstacle pixels).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.depth import disparity_to_depth
from stereo_obstacles.errors import InvalidInputError


@dataclass(frozen=True)
class DepthAgreement:
    """Relative depth error over the pixels compared (``None`` when there are none).

    ``median_relative_error_pct`` is in per cent; ``within_5pct`` is a fraction in [0, 1] (the
    share of the pixels within 5 %), as the JSON of ``evaluate-detection`` has it.
    """

    compared_px: int
    median_relative_error_pct: float | None
    within_5pct: float | None

    def to_dict(self) -> dict:
        """JSON-ready mapping."""
        return asdict(self)


def depth_agreement(disparity: np.ndarray, gt_disparity: np.ndarray, calibration: StereoCalibration,
                    mask: np.ndarray | None = None) -> DepthAgreement:
    """Compare depths of ``disparity`` and ``gt_disparity`` (both ``float (H, W)``, NaN invalid).

    Parameters
    ----------
    disparity, gt_disparity
        Disparity maps in pixels.
    calibration
        The calibration both depths are computed with.
    mask
        Optional ``bool (H, W)`` restricting the comparison.
    """
    z = disparity_to_depth(disparity, calibration)
    z_gt = disparity_to_depth(gt_disparity, calibration)
    if z.shape != z_gt.shape or (mask is not None and np.shape(mask) != z.shape):
        raise InvalidInputError(f"disparity {z.shape}, gt_disparity {z_gt.shape} and mask "
                                f"{None if mask is None else np.shape(mask)} must have one shape")
    use = np.isfinite(z) & np.isfinite(z_gt)
    if mask is not None:
        use &= np.asarray(mask, dtype=bool)
    if not use.any():
        return DepthAgreement(compared_px=0, median_relative_error_pct=None, within_5pct=None)
    relative = np.abs(z[use] - z_gt[use]) / z_gt[use]
    return DepthAgreement(compared_px=int(use.sum()), median_relative_error_pct=float(np.median(relative) * 100),
                          within_5pct=float(np.mean(relative <= 0.05)))
