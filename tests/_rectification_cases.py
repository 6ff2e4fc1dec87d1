"""Shared cases for the rectification tests: a mis-mounted synthetic right camera and a
Middlebury pair whose right camera is turned and shifted by a known amount."""

from __future__ import annotations

import numpy as np

from stereo_obstacles.camera_calibration import CameraPairCalibration
from stereo_obstacles.rectification_evaluation import synthetic_camera_pair, turn_right_camera
from stereo_obstacles.synthetic import RenderOptions, RightCameraError, default_scene, render_pair

SIZE = (320, 240)
RIGHT_ERROR = RightCameraError(rotation_deg=(0.6, -0.4, 0.8), vertical_offset_px=3.0)
MIDDLEBURY_TURN = {"focal_px": 450.0, "baseline_m": 0.1, "rotation_deg": (0.3, 0.0, 1.0), "shift_px": 2.5}


def synthetic_case(right_error: RightCameraError = RIGHT_ERROR):
    """``(pair, true CameraPairCalibration)`` of the default scene at :data:`SIZE`."""
    pair = render_pair(default_scene(*SIZE), RenderOptions(right_error=right_error))
    return pair, synthetic_camera_pair(pair)


def perturbed_middlebury(right: np.ndarray, gt_disparity: np.ndarray):
    """``(turned right image, depth, true calibration)`` with :data:`MIDDLEBURY_TURN`."""
    return turn_right_camera(right, gt_disparity, **MIDDLEBURY_TURN)


def truth_kwargs(calibration: CameraPairCalibration) -> dict:
    """Keyword arguments of :func:`rectified_ground_truth` from the true calibration."""
    return {"camera_matrix_left": calibration.camera_matrix_left, "camera_matrix_right": calibration.camera_matrix_right,
            "rotation": calibration.rotation, "translation_m": calibration.translation_m}
