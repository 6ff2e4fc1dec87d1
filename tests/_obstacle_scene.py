"""A small hand-made detection (image, labels, disparity, measured obstacles) for the output tests.

A level camera 1.2 m above flat ground sees a box at 4 m, a pole at 5 m in front of a wall at
8 m, and a flat marking painted on the ground (rejected as flat). 320 x 240 pixels.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.depth import disparity_to_depth
from stereo_obstacles.labels import Label
from stereo_obstacles.obstacle_grouping import group_obstacle_pixels
from stereo_obstacles.ground_plane import GroundPlane
from stereo_obstacles.obstacles import ObstacleList, measure_obstacles

RIG = StereoCalibration(focal_px=350.0, cx_px=160.0, cy_px=120.0, baseline_m=0.12, width_px=320, height_px=240)
CAMERA_HEIGHT_M = 1.2
GROUND = GroundPlane(a=0.0, b=RIG.baseline_m / CAMERA_HEIGHT_M, c=-RIG.baseline_m / CAMERA_HEIGHT_M * RIG.cy_px)
TRUE_DISTANCES_M = (4.0, 5.0, 8.0)


@dataclass(frozen=True)
class Detection:
    left: np.ndarray
    labels: np.ndarray
    disparity: np.ndarray
    depth_m: np.ndarray
    calibrated: ObstacleList
    uncalibrated: ObstacleList


def detection() -> Detection:
    """Build the scene and measure its obstacles with and without the calibration."""
    h, w = RIG.height_px, RIG.width_px
    yy, xx = np.mgrid[0:h, 0:w]
    d = np.where(yy > RIG.cy_px, GROUND.disparity_at(xx, yy), np.nan).astype(np.float32)
    labels = np.where(yy > RIG.cy_px, Label.GROUND, Label.SKY).astype(np.uint8)
    left = np.zeros((h, w, 3), np.uint8)
    left[yy <= RIG.cy_px] = (150, 190, 230)
    left[yy > RIG.cy_px] = (110, 110, 100)
    left[..., :] = np.clip(left.astype(int) + ((xx // 8 + yy // 8) % 2 * 20)[..., None], 0, 255)
    mask = np.zeros(d.shape, bool)

    def stand(x0, x1, z, height, rgb):
        bottom = int(round(RIG.cy_px + RIG.focal_px * CAMERA_HEIGHT_M / z))
        top = int(round(bottom - RIG.focal_px * height / z))
        d[top:bottom, x0:x1] = RIG.focal_baseline_px_m / z
        mask[top:bottom, x0:x1] = True
        labels[top:bottom, x0:x1] = Label.OBSTACLE
        left[top:bottom, x0:x1] = rgb

    stand(20, 100, 8.0, 2.0, (170, 120, 80))    # wall
    stand(50, 58, 5.0, 1.5, (40, 40, 160))      # pole in front of the wall
    stand(150, 200, 4.0, 1.0, (200, 160, 40))   # box
    mask[228:236, 225:300] = True               # marking painted on the ground
    labels[228:236, 225:300] = Label.OBSTACLE
    left[228:236, 225:300] = (240, 240, 240)
    labels[200:215, 30:60] = Label.SHADOW
    d[::4, ::3] = np.nan                        # semi-dense holes
    groups = group_obstacle_pixels(d, mask)
    return Detection(left=left, labels=labels, disparity=d, depth_m=disparity_to_depth(d, RIG),
                     calibrated=measure_obstacles(groups, d, RIG, GROUND),
                     uncalibrated=measure_obstacles(groups, d, None, GROUND))
