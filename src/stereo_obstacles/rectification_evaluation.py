"""Ground truth in the rectified frame, to measure a rectification and the matcher after it.

Ground-truth disparity belongs to the *original* left view. A rectification moves the left
pixels too (the calibrated one turns the left camera by ``R1``; the uncalibrated one applies
``H1``), so comparing a disparity of the rectified pair with the original ground truth would
be wrong. :func:`rectified_ground_truth` instead follows each rectified left pixel back to
the original left image (the rectification's look-up map), takes the depth there, builds the
3-D point, projects it into the true right camera (``R``, ``T``, ``K_right``) and forward
through the right rectification. The difference of the two rectified positions is the exact
disparity (horizontal) and the remaining rectification error (vertical) of that pixel.

Inverse depth is interpolated bilinearly (exact on planes, where it is linear in the pixel
coordinates), and only where it is continuous (a 3 x 3 neighbourhood within
:data:`SMOOTH_DEPTH_RATIO`): across a depth edge an interpolated depth belongs to no surface,
and those pixels are left out of the ground truth, like occluded ones.

Test cases: :func:`synthetic_camera_pair` (the true calibration of a rendered pair whose right
camera is mis-mounted) and :func:`turn_right_camera` (a real rectified pair, such as a
Middlebury one, whose right camera is turned and shifted by a known amount).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stereo_obstacles.camera_calibration import CameraPairCalibration
from stereo_obstacles.errors import ImageMismatchError, InvalidInputError
from stereo_obstacles.rectification_quality import VerticalOffsetStats, vertical_offset_stats

SMOOTH_DEPTH_RATIO = 1.25
"""Largest max/min depth ratio in a 3 x 3 neighbourhood where inverse depth is interpolated."""


@dataclass(frozen=True, eq=False)
class RectifiedTruth:
    """Exact correspondences of a rectified pair.

    Attributes
    ----------
    disparity : ndarray of float32, shape (H, W)
        Disparity of each rectified left pixel, pixels; NaN where unknown (sky, depth edges,
        outside the original image).
    nonocc : ndarray of bool, shape (H, W)
        Pixels with a disparity that are not occluded in the right view.
    vertical : VerticalOffsetStats
        Vertical offsets of the exact correspondences after rectification (pixels): the
        rectification's own error, free of feature localisation noise.
    """

    disparity: np.ndarray
    nonocc: np.ndarray
    vertical: VerticalOffsetStats


def rectified_ground_truth(rectification, depth_m: np.ndarray, nonocc: np.ndarray, *, camera_matrix_left: np.ndarray,
                           camera_matrix_right: np.ndarray, rotation: np.ndarray,
                           translation_m: np.ndarray) -> RectifiedTruth:
    """Map the original left view's depth into exact rectified-frame disparities.

    Parameters
    ----------
    rectification : Rectification or UncalibratedRectification
        Anything with ``maps`` (:class:`~stereo_obstacles.rectification.PairMaps`) and
        ``right_points(points)``.
    depth_m : ndarray, shape (H, W)
        Depth ``Z`` of the original left view (any length unit consistent with
        ``translation_m``), NaN where unknown.
    nonocc : ndarray of bool, shape (H, W)
        Original left pixels visible in the right view.
    camera_matrix_left, camera_matrix_right : ndarray, shape (3, 3)
        True camera matrices (no lens distortion).
    rotation, translation_m : ndarray
        True ``R`` (3, 3) and ``T`` (3,): a left-camera point ``X`` is ``R @ X + T`` in the right camera.

    Returns
    -------
    RectifiedTruth
    """
    import cv2

    depth = np.asarray(depth_m, dtype=np.float32)
    if depth.ndim != 2 or np.shape(nonocc) != depth.shape:
        raise ImageMismatchError(f"depth_m and nonocc: expected one (H, W) shape, got {depth.shape} and "
                                 f"{np.shape(nonocc)}")
    maps = rectification.maps
    if maps.left_x.shape != depth.shape:
        raise ImageMismatchError(f"depth_m is {depth.shape[1]}x{depth.shape[0]} but the rectification is for "
                                 f"{maps.left_x.shape[1]}x{maps.left_x.shape[0]} images")
    if np.shape(rotation) != (3, 3) or np.size(translation_m) != 3:
        raise InvalidInputError(f"rotation must be (3, 3) and translation_m 3 numbers, got {np.shape(rotation)} "
                                f"and {np.shape(translation_m)}")
    inverse = np.where(np.isfinite(depth) & (depth > 0), 1.0 / np.where(depth > 0, depth, 1.0), 0.0).astype(np.float32)
    kernel = np.ones((3, 3), np.uint8)
    high = cv2.dilate(np.where(np.isfinite(depth), depth, np.inf).astype(np.float32), kernel)
    low = cv2.erode(np.where(np.isfinite(depth), depth, 0.0).astype(np.float32), kernel)
    smooth = (low > 0) & np.isfinite(high) & (high <= SMOOTH_DEPTH_RATIO * low)
    usable = (smooth & nonocc).astype(np.uint8)

    sx, sy = maps.left_x, maps.left_y
    w = cv2.remap(inverse, sx, sy, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    known = cv2.remap(smooth.astype(np.uint8), sx, sy, cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT) > 0
    visible = cv2.remap(usable, sx, sy, cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT) > 0
    known &= w > 0

    height, width = depth.shape
    v, u = np.nonzero(known)
    source = np.c_[sx[v, u], sy[v, u], np.ones(v.size)]
    points = (source @ np.linalg.inv(camera_matrix_left).T) / w[v, u, None]
    in_right = points @ np.asarray(rotation, dtype=np.float64).T + np.asarray(translation_m, dtype=np.float64).ravel()
    projected = in_right @ np.asarray(camera_matrix_right, dtype=np.float64).T
    right_px = rectification.right_points(projected[:, :2] / projected[:, 2:3])

    disparity = np.full((height, width), np.nan, np.float32)
    disparity[v, u] = u - right_px[:, 0]
    vertical = vertical_offset_stats(np.c_[u, v].astype(np.float64)[visible[v, u]], right_px[visible[v, u]])
    return RectifiedTruth(disparity=disparity, nonocc=visible & known, vertical=vertical)


def synthetic_camera_pair(pair) -> CameraPairCalibration:
    """The true :class:`CameraPairCalibration` of a rendered :class:`~stereo_obstacles.synthetic.SyntheticPair`."""
    k = pair.scene.rig.intrinsic_matrix()
    height, width = pair.left.shape[:2]
    return CameraPairCalibration(k, None, pair.right_intrinsics, None, pair.right_rotation, pair.right_translation_m,
                                 width, height)


def turn_right_camera(right: np.ndarray, gt_disparity: np.ndarray, *, focal_px: float, baseline_m: float,
                      rotation_deg: tuple[float, float, float], shift_px: float
                      ) -> tuple[np.ndarray, np.ndarray, CameraPairCalibration]:
    """Turn and shift the right camera of a rectified pair by a known amount.

    The new right camera is the old one rotated by ``rotation_deg`` (degrees about X, Y, Z;
    the columns of ``Rx Ry Rz`` are its axes in the old frame) with its principal point moved
    down by ``shift_px``. Its image is the old one warped by ``K_new R^T K^-1``, which is
    exact for a rotation about the optical centre; ``K`` has the assumed ``focal_px`` and the
    image centre as principal point (an in-plane turn and a shift do not depend on the focal
    length; a tilt or pan does, consistently with the returned calibration).

    Parameters
    ----------
    right : ndarray, shape (H, W[, 3])
        Right image of a rectified pair.
    gt_disparity : ndarray, shape (H, W)
        Ground-truth left disparity, pixels (NaN or <= 0 unknown).
    focal_px, baseline_m : float
        Assumed focal length and baseline (they set the depth scale only).
    rotation_deg, shift_px
        The known turn and vertical shift of the right camera.

    Returns
    -------
    right : ndarray
        The turned right image (same shape and dtype).
    depth_m : ndarray of float32, shape (H, W)
        ``focal_px * baseline_m / d``, NaN where unknown.
    calibration : CameraPairCalibration
        The true calibration of the turned pair.
    """
    import cv2

    from stereo_obstacles.synthetic.rig import rotation_xyz

    height, width = right.shape[:2]
    k = np.array([[focal_px, 0.0, (width - 1) / 2.0], [0.0, focal_px, (height - 1) / 2.0], [0.0, 0.0, 1.0]])
    k_new = k.copy()
    k_new[1, 2] += shift_px
    turn = rotation_xyz(rotation_deg)
    warped = cv2.warpPerspective(right, k_new @ turn.T @ np.linalg.inv(k), (width, height), flags=cv2.INTER_LINEAR)
    gt = np.asarray(gt_disparity, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        depth = np.where(gt > 0, focal_px * baseline_m / gt, np.nan).astype(np.float32)
    rotation = turn.T
    calibration = CameraPairCalibration(k, None, k_new, None, rotation, -rotation @ np.array([baseline_m, 0.0, 0.0]),
                                        width, height)
    return warped, depth, calibration
