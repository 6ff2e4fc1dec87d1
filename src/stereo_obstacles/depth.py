"""Depth and 3-D points from disparity: ``Z = f B / (d + doffs)``.

Frame of the 3-D points: the rectified left camera, x to the right, y down, z forward along
the optical axis, in metres (the OpenCV convention). Invalid stays invalid: a NaN or
non-positive ``d + doffs`` gives NaN depth, never a huge number.
"""

from __future__ import annotations

import numpy as np

from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import is_finite_real
from stereo_obstacles.float_maps import check_float_map


def _check_calibration(calibration: object) -> StereoCalibration:
    """``calibration`` itself, or :class:`InvalidInputError`: depth needs one (``None`` gave an
    AttributeError from deep inside)."""
    if not isinstance(calibration, StereoCalibration):
        raise InvalidInputError(f"calibration must be a StereoCalibration (depth needs one), got "
                                f"{type(calibration).__name__}")
    return calibration


def disparity_to_depth(disparity: np.ndarray, calibration: StereoCalibration) -> np.ndarray:
    """Depth in metres, ``float32 (H, W)``: ``Z = f B / (d + doffs)``, NaN where the disparity is
    missing or ``d + doffs <= 0`` (with Middlebury's ``doffs`` a disparity of 0 is a finite, far
    depth: mark unmatched pixels NaN, not 0).

    Parameters
    ----------
    disparity
        Left-view disparity in pixels, ``(H, W)`` float, NaN where unmatched.
    calibration
        The rectified calibration (``focal_px``, ``baseline_m``, ``doffs_px``).
    """
    d = check_float_map(disparity, "disparity").astype(np.float32, copy=False)
    d = d.astype(np.float64) + _check_calibration(calibration).doffs_px
    depth = np.full(d.shape, np.nan, dtype=np.float32)
    valid = np.isfinite(d) & (d > 0)
    depth[valid] = (calibration.focal_baseline_px_m / d[valid]).astype(np.float32)
    return depth


def depth_to_disparity(depth_m: np.ndarray, calibration: StereoCalibration) -> np.ndarray:
    """Disparity in pixels from depth in metres (the inverse of :func:`disparity_to_depth`)."""
    z = check_float_map(depth_m, "depth").astype(np.float32, copy=False).astype(np.float64)
    _check_calibration(calibration)
    disparity = np.full(z.shape, np.nan, dtype=np.float32)
    valid = np.isfinite(z) & (z > 0)
    disparity[valid] = (calibration.focal_baseline_px_m / z[valid] - calibration.doffs_px).astype(np.float32)
    return disparity


def points_from_depth(depth_m: np.ndarray, calibration: StereoCalibration) -> np.ndarray:
    """3-D points ``float32 (H, W, 3)`` in metres in the left camera frame; NaN where depth is NaN."""
    z = check_float_map(depth_m, "depth").astype(np.float32, copy=False)
    _check_calibration(calibration)
    h, w = z.shape
    xs = (np.arange(w, dtype=np.float32) - np.float32(calibration.cx_px)) / np.float32(calibration.focal_px)
    ys = (np.arange(h, dtype=np.float32) - np.float32(calibration.cy_px)) / np.float32(calibration.focal_px)
    points = np.empty((h, w, 3), dtype=np.float32)
    points[..., 0] = xs[None, :] * z
    points[..., 1] = ys[:, None] * z
    points[..., 2] = z
    return points


def depth_uncertainty_m(depth_m: np.ndarray, calibration: StereoCalibration,
                        disparity_error_px: float | np.ndarray = 1.0) -> np.ndarray:
    """Depth error caused by a disparity error: ``Z**2 / (f B) * disparity_error_px``, metres.
    ``disparity_error_px``: pixels, finite and >= 0; one number, or a map broadcasting against
    ``depth_m`` (such as :func:`stereo_obstacles.disparity_uncertainty.disparity_sigma_px`'s)."""
    z = check_float_map(depth_m, "depth").astype(np.float32, copy=False)
    _check_calibration(calibration)
    if np.ndim(disparity_error_px) == 0:
        value = disparity_error_px.item() if isinstance(disparity_error_px, np.ndarray) else disparity_error_px
        if not (is_finite_real(value) and value >= 0):
            raise InvalidInputError(f"disparity_error_px must be a finite number >= 0, got {value!r}")
    else:
        error = np.asarray(disparity_error_px, dtype=np.float64)
        if not (np.isfinite(error).all() and (error >= 0).all()):
            raise InvalidInputError(f"disparity_error_px: a map {error.shape} with values that are not finite and >= 0")
        try:
            fits = np.broadcast_shapes(z.shape, error.shape) == z.shape
        except ValueError:
            fits = False
        if not fits:
            raise InvalidInputError(f"disparity_error_px: a map {error.shape} does not fit the depth map {z.shape}")
    error = np.asarray(disparity_error_px, dtype=np.float32)
    return (z * z / np.float32(calibration.focal_baseline_px_m) * error).astype(np.float32)
