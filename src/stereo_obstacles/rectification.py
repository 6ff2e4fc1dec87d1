"""Calibrated rectification: from a :class:`CameraPairCalibration` to a rectified pair.

:func:`rectify_calibration` runs ``cv2.stereoRectify`` (rotations ``R1``, ``R2``, projections
``P1``, ``P2``, reprojection matrix ``Q``; principal points made equal so that ``doffs = 0``)
and ``cv2.initUndistortRectifyMap`` once; the returned :class:`Rectification` then rectifies
any number of frames with ``cv2.remap`` (:meth:`Rectification.apply`). Its ``rectified``
attribute is the :class:`~stereo_obstacles.calibration.StereoCalibration` of the rectified
pair: depth computed from disparities of rectified images is in the *rectified left camera*
frame, which is the original left camera turned by ``R1``.
"""

from __future__ import annotations

import logging
import os
from dataclasses import dataclass

import numpy as np

from stereo_obstacles.calibration import StereoCalibration, sized_for_images
from stereo_obstacles.camera_calibration import CameraPairCalibration
from stereo_obstacles.errors import CalibrationError, ImageMismatchError, InvalidInputError

logger = logging.getLogger(__name__)


@dataclass(frozen=True, eq=False)
class PairMaps:
    """Pixel look-up maps of a rectification, for ``cv2.remap``.

    ``left_x[v, u], left_y[v, u]`` is where rectified left pixel ``(u, v)`` comes from in the
    original left image (likewise for the right); ``float32 (H, W)`` each.
    """

    left_x: np.ndarray
    left_y: np.ndarray
    right_x: np.ndarray
    right_y: np.ndarray

    def apply(self, left: np.ndarray, right: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Rectify one pair (bilinear interpolation; pixels from outside the image are black).

        Parameters
        ----------
        left, right : ndarray, shape (H, W) or (H, W, 3)
            Original images of the calibrated size, any dtype OpenCV remaps (uint8, uint16, float32).

        Returns
        -------
        tuple of ndarray
            Rectified left and right, same shapes and dtypes.
        """
        import cv2

        height, width = self.left_x.shape
        for name, image in (("left", left), ("right", right)):
            if not isinstance(image, np.ndarray) or image.ndim < 2:
                raise ImageMismatchError(f"{name} image must be an image array, got {type(image).__name__}")
            if image.shape[:2] != (height, width):
                raise ImageMismatchError(f"{name} image must be {width}x{height} like the rectification, got "
                                         f"{image.shape[1]}x{image.shape[0]}")
        rectified_left = cv2.remap(left, self.left_x, self.left_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
        rectified_right = cv2.remap(right, self.right_x, self.right_y, cv2.INTER_LINEAR,
                                    borderMode=cv2.BORDER_CONSTANT)
        return rectified_left, rectified_right


@dataclass(frozen=True, eq=False)
class Rectification:
    """The rectification of a calibrated pair, reusable for every frame.

    Attributes
    ----------
    calibration : CameraPairCalibration
        What it was computed from.
    r1, r2 : ndarray, shape (3, 3)
        Rotations from each original camera frame to its rectified frame.
    p1, p2 : ndarray, shape (3, 4)
        Projection matrices of the rectified cameras (in the rectified left frame).
    q : ndarray, shape (4, 4)
        OpenCV's disparity-to-depth reprojection matrix.
    rectified : StereoCalibration
        The rectified pair's calibration (``doffs_px = 0``).
    maps : PairMaps
        Look-up maps for :meth:`apply`.
    """

    calibration: CameraPairCalibration
    r1: np.ndarray
    r2: np.ndarray
    p1: np.ndarray
    p2: np.ndarray
    q: np.ndarray
    rectified: StereoCalibration
    maps: PairMaps

    def apply(self, left: np.ndarray, right: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Rectify one frame; see :meth:`PairMaps.apply`."""
        return self.maps.apply(left, right)

    def left_points(self, points_px: np.ndarray) -> np.ndarray:
        """Rectified coordinates ``(N, 2)`` of original left image points ``(N, 2)``."""
        return _rectify_points(points_px, self.calibration.camera_matrix_left, self.calibration.distortion_left,
                               self.r1, self.p1)

    def right_points(self, points_px: np.ndarray) -> np.ndarray:
        """Rectified coordinates ``(N, 2)`` of original right image points ``(N, 2)``."""
        return _rectify_points(points_px, self.calibration.camera_matrix_right,
                               self.calibration.distortion_right, self.r2, self.p2)

    def report(self, calibration_file: str | os.PathLike[str]) -> dict:
        """JSON-ready record of rectifying with the file ``calibration_file``, as the outputs
        store it (``run.inputs.rectification``): method, file, rectified calibration."""
        return {"method": "calibrated", "calibration": os.fspath(calibration_file),
                "rectified": self.rectified.to_dict()}

    def opencv_matrices(self) -> dict[str, np.ndarray]:
        """``R1``, ``R2``, ``P1``, ``P2``, ``Q`` under OpenCV's names (for its YAML files)."""
        return {"R1": self.r1, "R2": self.r2, "P1": self.p1, "P2": self.p2, "Q": self.q}


def _rectify_points(points_px: np.ndarray, k: np.ndarray, distortion: np.ndarray, r: np.ndarray,
                    p: np.ndarray) -> np.ndarray:
    import cv2

    points = np.asarray(points_px, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 2:
        raise InvalidInputError(f"points_px: expected (N, 2), got {points.shape}")
    if points.shape[0] == 0:
        return points.copy()
    return cv2.undistortPoints(points.reshape(-1, 1, 2), k, distortion, R=r, P=p).reshape(-1, 2)


def rig_for_images(calibration: StereoCalibration | CameraPairCalibration, width_px: int,
                   height_px: int) -> tuple[StereoCalibration, Rectification | None]:
    """The calibration of ``width_px x height_px`` images taken with ``calibration``, and the
    rectification to apply to them first (``None`` when they are taken as rectified).

    A rectified rig's calibration is checked against the images
    (:func:`~stereo_obstacles.calibration.sized_for_images`: the size, and a warning for a
    principal point far off centre); the raw cameras' (as ``calibrate`` writes them) must be of
    the images' size and gives the rectified calibration with its rectification.

    Raises
    ------
    CalibrationError
        A calibration of other images.
    """
    if not isinstance(calibration, CameraPairCalibration):
        return sized_for_images(calibration, width_px, height_px), None
    calibration.check_image_size(width_px, height_px)
    rectification = rectify_calibration(calibration)
    return rectification.rectified, rectification


def rectify_calibration(calibration: CameraPairCalibration, *, alpha: float = 0.0) -> Rectification:
    """Compute the rectification of a calibrated horizontal pair (once per rig).

    Parameters
    ----------
    calibration : CameraPairCalibration
        Both cameras' matrices and distortion, ``R``, ``T`` (metres), image size.
    alpha : float
        OpenCV's free scaling in [0, 1]: 0 zooms so every rectified pixel is valid (no black
        border; the default, because black borders would be matched and segmented), 1 keeps
        every original pixel.

    Returns
    -------
    Rectification

    Raises
    ------
    CalibrationError
        A vertical rig, or the right camera on the left of the left camera (swapped images).

    Examples
    --------
    >>> import numpy as np
    >>> k = [[500.0, 0, 159.5], [0, 500.0, 119.5], [0, 0, 1]]
    >>> pair = CameraPairCalibration(k, None, k, None, np.eye(3), [-0.1, 0, 0], 320, 240)
    >>> round(rectify_calibration(pair).rectified.baseline_m, 3)
    0.1
    """
    import cv2

    if not 0.0 <= alpha <= 1.0:
        raise InvalidInputError(f"alpha: expected 0 <= alpha <= 1, got {alpha}")
    t = calibration.translation_m
    if abs(t[1]) > abs(t[0]) or abs(t[2]) > abs(t[0]):
        raise CalibrationError(f"the calibration describes a rig whose cameras are not side by side "
                               f"(T = {np.round(t, 4).tolist()} m); only horizontal rigs are supported")
    if t[0] > 0:
        raise CalibrationError(f"the right camera is on the left of the left camera (T[0] = {t[0]:.4g} m > 0): "
                               f"the left and right images (or cameras) are swapped")
    size = calibration.image_size
    r1, r2, p1, p2, q, _, _ = cv2.stereoRectify(
        calibration.camera_matrix_left, calibration.distortion_left, calibration.camera_matrix_right,
        calibration.distortion_right, size, calibration.rotation, calibration.translation_m.reshape(3, 1),
        flags=cv2.CALIB_ZERO_DISPARITY, alpha=alpha)
    focal = float(p1[0, 0])
    baseline = -float(p2[0, 3]) / float(p2[0, 0])
    rectified = StereoCalibration(focal_px=focal, cx_px=float(p1[0, 2]), cy_px=float(p1[1, 2]), baseline_m=baseline,
                                  width_px=size[0], height_px=size[1], doffs_px=float(p2[0, 2] - p1[0, 2]))
    left_x, left_y = cv2.initUndistortRectifyMap(calibration.camera_matrix_left, calibration.distortion_left,
                                                 r1, p1, size, cv2.CV_32FC1)
    right_x, right_y = cv2.initUndistortRectifyMap(calibration.camera_matrix_right, calibration.distortion_right,
                                                   r2, p2, size, cv2.CV_32FC1)
    logger.info("rectified pair: f = %.2f px, B = %.4f m, principal point (%.1f, %.1f)", focal, baseline,
                rectified.cx_px, rectified.cy_px)
    return Rectification(calibration=calibration, r1=r1, r2=r2, p1=p1, p2=p2, q=q, rectified=rectified,
                         maps=PairMaps(left_x, left_y, right_x, right_y))
