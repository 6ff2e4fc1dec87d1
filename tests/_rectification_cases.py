"""Shared cases for the rectification tests: a mis-mounted synthetic right camera and a
Middlebury pair whose right image is turned and shifted by a known camera motion."""

from __future__ import annotations

import numpy as np

from stereo_obstacles.camera_calibration import CameraPairCalibration
from stereo_obstacles.synthetic import RenderOptions, RightCameraError, default_scene, render_pair
from stereo_obstacles.synthetic.rig import rotation_xyz

SIZE = (320, 240)
RIGHT_ERROR = RightCameraError(rotation_deg=(0.6, -0.4, 0.8), vertical_offset_px=3.0)

MIDDLEBURY_FOCAL_PX = 450.0
"""Assumed focal length for the Middlebury pair (any value works for an in-plane turn; it fixes the tilt's effect)."""
MIDDLEBURY_BASELINE_M = 0.1
MIDDLEBURY_ROTATION_DEG = (0.3, 0.0, 1.0)
MIDDLEBURY_SHIFT_PX = 2.5


def synthetic_case(right_error: RightCameraError = RIGHT_ERROR):
    """``(pair, true CameraPairCalibration)`` of the default scene at :data:`SIZE`."""
    scene = default_scene(*SIZE)
    pair = render_pair(scene, RenderOptions(right_error=right_error))
    k = scene.rig.intrinsic_matrix()
    calibration = CameraPairCalibration(k, None, pair.right_intrinsics, None, pair.right_rotation,
                                        pair.right_translation_m, *SIZE)
    return pair, calibration


def perturbed_middlebury(left: np.ndarray, right: np.ndarray, gt_disparity: np.ndarray):
    """Turn and shift the right camera of a rectified pair; return ``(right, depth, calibration)``.

    The new right camera is the old one rotated by :data:`MIDDLEBURY_ROTATION_DEG` (columns of
    ``Rx Ry Rz`` are its axes in the old frame) with its principal point moved down by
    :data:`MIDDLEBURY_SHIFT_PX`; its image is the old one warped by ``K_new R^T K^-1``, exact
    for a rotation about the optical centre. Depth follows from the ground truth with the
    assumed focal length and baseline.
    """
    import cv2

    height, width = left.shape[:2]
    k = np.array([[MIDDLEBURY_FOCAL_PX, 0, (width - 1) / 2], [0, MIDDLEBURY_FOCAL_PX, (height - 1) / 2], [0, 0, 1]])
    k_new = k.copy()
    k_new[1, 2] += MIDDLEBURY_SHIFT_PX
    turn = rotation_xyz(MIDDLEBURY_ROTATION_DEG)
    warped = cv2.warpPerspective(right, k_new @ turn.T @ np.linalg.inv(k), (width, height), flags=cv2.INTER_LINEAR)
    rotation = turn.T
    translation = -rotation @ np.array([MIDDLEBURY_BASELINE_M, 0.0, 0.0])
    with np.errstate(divide="ignore", invalid="ignore"):
        depth = np.where(gt_disparity > 0, MIDDLEBURY_FOCAL_PX * MIDDLEBURY_BASELINE_M / gt_disparity, np.nan)
    calibration = CameraPairCalibration(k, None, k_new, None, rotation, translation, width, height)
    return warped, depth.astype(np.float32), calibration


def truth_kwargs(calibration: CameraPairCalibration) -> dict:
    """Keyword arguments of :func:`rectified_ground_truth` from the true calibration."""
    return {"camera_matrix_left": calibration.camera_matrix_left, "camera_matrix_right": calibration.camera_matrix_right,
            "rotation": calibration.rotation, "translation_m": calibration.translation_m}
