"""Grouping obstacle pixels into objects and measuring them against a known geometry."""

from __future__ import annotations

import numpy as np
import pytest

from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.obstacle_grouping import GroupingParameters, group_obstacle_pixels
from stereo_obstacles.obstacles import DisparityPlane, ObstacleParameters, corridor_summary, measure_obstacles

RIG = StereoCalibration(focal_px=700.0, cx_px=320.0, cy_px=240.0, baseline_m=0.12, width_px=640, height_px=480)
CAMERA_HEIGHT_M = 1.2
# A level camera 1.2 m above the ground sees the ground at d = B / h * (y - cy).
GROUND = DisparityPlane(a=0.0, b=RIG.baseline_m / CAMERA_HEIGHT_M, c=-RIG.baseline_m / CAMERA_HEIGHT_M * RIG.cy_px)


def _scene():
    """Ground, a 1 m box at 4 m, a pole at 5 m in front of a wall at 8 m, a flat marking."""
    yy, xx = np.mgrid[0:480, 0:640]
    d = np.where(yy > 240, GROUND.disparity_at(xx, yy), np.nan).astype(np.float32)
    mask = np.zeros(d.shape, bool)

    def stand(x0, x1, z, height):
        d_obj = RIG.focal_baseline_px_m / z
        bottom = int(round(RIG.cy_px + RIG.focal_px * CAMERA_HEIGHT_M / z))
        top = int(round(bottom - RIG.focal_px * height / z))
        d[top:bottom, x0:x1] = d_obj
        mask[top:bottom, x0:x1] = True

    stand(40, 200, 8.0, 2.0)      # wall
    stand(100, 115, 5.0, 1.5)     # pole in front of the wall
    stand(300, 400, 4.0, 1.0)     # box
    mask[455:470, 450:600] = True  # marking painted on the ground
    d[::4, ::3] = np.nan           # semi-dense holes
    return d, mask


def test_pole_in_front_of_wall_is_a_separate_object_and_marking_is_rejected():
    d, mask = _scene()
    groups = group_obstacle_pixels(d, mask)
    result = measure_obstacles(groups, d, RIG, GROUND)
    distances = [o.distance_m for o in result.obstacles]
    assert distances == pytest.approx([4.0, 5.0, 8.0], rel=0.01)
    box, pole, wall = result.obstacles
    assert [o.id for o in result.obstacles] == [1, 2, 3]
    assert pole.height_above_ground_m == pytest.approx(1.5, rel=0.06)
    assert box.height_above_ground_m == pytest.approx(1.0, rel=0.06)
    assert box.width_m == pytest.approx(100 * 4.0 / 700, rel=0.06)
    assert box.box_px == (300, 275, 400, 450)
    assert len(result.rejected) == 1 and "flat on the ground" in result.rejected[0].reason
    assert result.rejected[0].box_px[1] >= 455
    assert set(np.unique(result.id_map).tolist()) == {0, 1, 2, 3}
    assert (result.id_map[300:440, 310:390] == 1).mean() > 0.5  # the box's own pixels carry its id
    assert (result.id_map[455:470, 450:600] == 0).all()        # the rejected marking carries none


def test_without_calibration_results_stay_in_pixels():
    d, mask = _scene()
    result = measure_obstacles(group_obstacle_pixels(d, mask), d, None, GROUND)
    assert all(o.distance_m is None and o.centre_m is None for o in result.obstacles)
    assert sorted(round(o.disparity_px, 1) for o in result.obstacles) == [10.5, 16.8, 21.0]
    assert result.corridor is None
    assert len(result.rejected) == 1


def test_without_ground_plane_nothing_is_rejected_as_flat():
    d, mask = _scene()
    d[455:470, 450:600] = GROUND.disparity_at(np.arange(450, 600)[None, :], np.arange(455, 470)[:, None])
    result = measure_obstacles(group_obstacle_pixels(d, mask), d, RIG, None)
    assert len(result.obstacles) == 4 and result.rejected == ()
    assert all(o.height_above_ground_m is None for o in result.obstacles)


def test_far_groups_are_rejected_with_the_reason():
    d, mask = _scene()
    result = measure_obstacles(group_obstacle_pixels(d, mask), d, RIG, GROUND, ObstacleParameters(max_distance_m=6.0))
    assert [o.distance_m for o in result.obstacles] == pytest.approx([4.0, 5.0], rel=0.01)
    assert any("farther than 6 m" in r.reason for r in result.rejected)


def test_corridor_finds_the_nearest_obstacle_ahead():
    d, mask = _scene()
    result = measure_obstacles(group_obstacle_pixels(d, mask), d, RIG, GROUND)
    assert result.corridor.nearest_obstacle_id == 1 and result.corridor.free_distance_m == pytest.approx(4.0, rel=0.01)
    assert corridor_summary(result.obstacles[1:], 1.0).nearest_obstacle_id is None


def test_small_groups_are_noise():
    d = np.full((50, 50), 20.0, np.float32)
    mask = np.zeros((50, 50), bool)
    mask[10:14, 10:14] = True
    assert group_obstacle_pixels(d, mask).max() == 0
    assert group_obstacle_pixels(d, mask, GroupingParameters(min_object_pixels=10)).max() == 1


def test_bad_arguments():
    with pytest.raises(InvalidInputError, match="same 2-D shape"):
        group_obstacle_pixels(np.zeros((3, 3), np.float32), np.zeros((3, 4), bool))
    with pytest.raises(InvalidInputError, match="cell_px"):
        GroupingParameters(cell_px=1)
    with pytest.raises(InvalidInputError, match="max_distance_m"):
        ObstacleParameters(max_distance_m=float("nan"))
