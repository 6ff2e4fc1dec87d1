"""Grouping obstacle pixels into objects and measuring them against a known geometry."""

from __future__ import annotations

import numpy as np
import pytest
from _obstacle_scene import CAMERA_HEIGHT_M, GROUND, RIG, TRUE_DISTANCES_M, detection

from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.ground_plane import GroundPlane, height_above_ground_m, tilt_from_camera_vertical_deg
from stereo_obstacles.obstacle_grouping import GroupingParameters, group_obstacle_pixels
from stereo_obstacles.obstacles import (ObstacleParameters, corridor_summary, list_obstacles, measure_groups,
                                        measure_obstacles, measure_without)


def test_pole_in_front_of_wall_is_a_separate_object_and_marking_is_rejected():
    result = detection().calibrated
    assert [o.distance_m for o in result.obstacles] == pytest.approx(TRUE_DISTANCES_M, rel=0.01)
    box, pole, wall = result.obstacles
    assert [o.id for o in result.obstacles] == [1, 2, 3]
    assert pole.height_above_ground_m == pytest.approx(1.5, rel=0.06)
    assert box.height_above_ground_m == pytest.approx(1.0, rel=0.06)
    assert wall.height_above_ground_m == pytest.approx(2.0, rel=0.06)
    assert box.width_m == pytest.approx(50 * 4.0 / RIG.focal_px, rel=0.06)
    assert box.box_px[0] == 150 and box.box_px[2] == 200
    assert len(result.rejected) == 1 and "flat on the ground" in result.rejected[0].reason
    assert result.rejected[0].box_px[1] >= 228
    assert set(np.unique(result.id_map).tolist()) == {0, 1, 2, 3}
    assert (result.id_map[box.box_px[1]:box.box_px[3], 150:200] == 1).mean() > 0.5
    assert (result.id_map[228:236, 225:300] == 0).all()


def test_groups_left_out_of_the_list_are_as_if_never_grouped():
    """The pipeline measures the flat groups before it knows which are obstacles' feet, and lists
    the others: the same list as measuring those others alone."""
    scene = detection()
    mask = scene.calibrated.id_map > 0
    mask[228:236, 225:300] = True                                 # the marking: a rejected group
    groups = group_obstacle_pixels(scene.disparity, mask)
    measured = measure_groups(groups, scene.disparity, RIG, GROUND)
    assert len(measured) == 4
    for left_out in ({1}, {int(groups[230, 250])}, {1, 3}):
        alone = measure_obstacles(np.where(np.isin(groups, list(left_out)), 0, groups), scene.disparity, RIG, GROUND)
        listed = list_obstacles({g: m for g, m in measured.items() if g not in left_out}, groups, scene.disparity, RIG)
        assert listed.obstacles == alone.obstacles and listed.rejected == alone.rejected
        np.testing.assert_array_equal(listed.id_map, alone.id_map)
        assert listed.corridor == alone.corridor and listed.scan == alone.scan


def test_a_list_of_other_groups_is_refused():
    scene = detection()
    groups = group_obstacle_pixels(scene.disparity, scene.calibrated.id_map > 0)
    measured = measure_groups(groups, scene.disparity, RIG, GROUND)
    for bad in ({**measured, int(groups.max()) + 1: measured[1]}, {0: measured[1]}, {1.0: measured[1]}):
        with pytest.raises(InvalidInputError, match="numbers of groups"):
            list_obstacles(bad, groups, scene.disparity, RIG)
    with pytest.raises(InvalidInputError, match="same 2-D shape"):
        list_obstacles(measured, groups, scene.disparity[:-1], RIG)


def test_without_calibration_results_stay_in_pixels():
    result = detection().uncalibrated
    assert all(o.distance_m is None and o.centre_m is None for o in result.obstacles)
    expected = sorted(round(RIG.focal_baseline_px_m / z, 1) for z in TRUE_DISTANCES_M)
    assert sorted(round(o.disparity_px, 1) for o in result.obstacles) == expected
    assert result.corridor is None
    assert len(result.rejected) == 1


def test_without_ground_plane_nothing_is_rejected_as_flat():
    scene = detection()
    mask = scene.calibrated.id_map > 0
    mask[228:236, 225:300] = True
    result = measure_obstacles(group_obstacle_pixels(scene.disparity, mask), scene.disparity, RIG, None)
    assert len(result.obstacles) == 4 and result.rejected == ()
    assert all(o.height_above_ground_m is None for o in result.obstacles)


def test_far_groups_are_rejected_with_the_reason():
    scene = detection()
    mask = scene.calibrated.id_map > 0
    result = measure_obstacles(group_obstacle_pixels(scene.disparity, mask), scene.disparity, RIG, GROUND,
                               ObstacleParameters(max_distance_m=6.0))
    assert [o.distance_m for o in result.obstacles] == pytest.approx([4.0, 5.0], rel=0.01)
    assert any("farther than 6 m" in r.reason for r in result.rejected)


def test_corridor_finds_the_nearest_obstacle_ahead():
    result = detection().calibrated
    box = result.obstacles[0]
    assert box.lateral_extent_m[0] < 0.5 and box.lateral_extent_m[1] > -0.5
    assert result.corridor.nearest_obstacle_id == 1
    assert result.corridor.free_distance_m == pytest.approx(4.0, rel=0.01)
    assert corridor_summary(result.obstacles[1:], 1.0).nearest_obstacle_id is None


def test_height_above_ground_of_known_points():
    points = np.array([[0.0, CAMERA_HEIGHT_M, 6.0], [1.0, CAMERA_HEIGHT_M - 0.5, 3.0], [0.0, 0.0, 5.0]])
    np.testing.assert_allclose(height_above_ground_m(GROUND, points, RIG), [0.0, 0.5, CAMERA_HEIGHT_M], atol=1e-9)


def test_tilt_tells_the_ground_from_a_wall():
    assert tilt_from_camera_vertical_deg(GROUND, RIG) == pytest.approx(0.0, abs=1e-9)
    wall_2m = GroundPlane(a=0.0, b=0.0, c=RIG.focal_baseline_px_m / 2.0)  # d constant: a wall facing the camera
    assert tilt_from_camera_vertical_deg(wall_2m, RIG) == pytest.approx(90.0)


def test_group_numbers_need_not_be_contiguous():
    scene = detection()
    groups = group_obstacle_pixels(scene.disparity, scene.calibrated.id_map > 0)
    gappy = np.where(groups > 0, groups * 5, 0)
    result = measure_obstacles(gappy, scene.disparity, RIG, GROUND)
    assert [o.distance_m for o in result.obstacles] == [o.distance_m for o in scene.calibrated.obstacles]


def test_measuring_again_without_some_pixels_is_measuring_the_groups_left():
    """Part of one group and all of another taken out: the groups that lost pixels are measured
    again, the one that lost them all is gone, the untouched one is kept as it was measured."""
    scene = detection()
    groups = group_obstacle_pixels(scene.disparity, scene.calibrated.id_map > 0)
    assert groups.max() >= 3
    taken_out = groups == 3
    ys, xs = np.nonzero(groups == 1)
    taken_out[ys[: len(ys) // 3], xs[: len(ys) // 3]] = True
    measured = measure_groups(groups, scene.disparity, RIG, GROUND)
    left, again = measure_without(taken_out, groups, measured, scene.disparity, RIG, GROUND)
    assert np.array_equal(left, np.where(taken_out, 0, groups))
    assert again == measure_groups(left, scene.disparity, RIG, GROUND)
    assert 3 not in again and again[1] != measured[1] and again[2] is measured[2]
    assert list(again) == sorted(again)


@pytest.mark.parametrize("seed", range(3))
def test_measurements_equal_numpy_percentiles_on_noisy_disparities(seed):
    """A box of noisy, tied disparities (no ground plane: every pixel is measured): the reported
    disparity, confidence, centre and extent are NumPy's percentiles and medians, rounded."""
    rng = np.random.default_rng(seed)
    d = np.full((RIG.height_px, RIG.width_px), np.nan, np.float32)
    d[60:150, 90:200] = np.round(rng.normal(20.0, 1.5, (90, 110)), 1).astype(np.float32)
    groups = np.zeros(d.shape, np.int32)
    groups[60:150, 90:200] = 1
    groups[0, 0] = -3                                             # a negative number reads as no group
    (obstacle,) = measure_obstacles(groups, d, RIG, None).obstacles
    ys, xs = np.nonzero(groups == 1)
    disparities = d[ys, xs].astype(np.float64)
    z = RIG.focal_baseline_px_m / (disparities + RIG.doffs_px)
    points = np.stack([(xs - RIG.cx_px) * z / RIG.focal_px, (ys - RIG.cy_px) * z / RIG.focal_px, z], axis=-1)
    quartiles = np.percentile(disparities, (25.0, 50.0, 75.0))
    (x_lo, _), (x_hi, _) = np.percentile(points[:, :2], (1.0, 99.0), axis=0)
    assert obstacle.disparity_px == round(float(quartiles[1]), 3)
    assert obstacle.centre_m == tuple(round(float(v), 3) for v in np.median(points, axis=0))
    assert obstacle.lateral_extent_m == (round(float(x_lo), 3), round(float(x_hi), 3))
    spread = float(quartiles[2] - quartiles[0])
    size_term = 1.0 - np.exp(-ys.size / 300.0)
    assert obstacle.confidence == round(size_term / (1.0 + spread / max(1.0, 0.1 * float(quartiles[1]))), 3)


def test_small_groups_are_noise():
    d = np.full((50, 50), 20.0, np.float32)
    mask = np.zeros((50, 50), bool)
    mask[10:14, 10:14] = True
    assert group_obstacle_pixels(d, mask).max() == 0
    assert group_obstacle_pixels(d, mask, GroupingParameters(min_object_pixels=10)).max() == 1


def test_bad_arguments():
    with pytest.raises(InvalidInputError, match="same 2-D shape"):
        group_obstacle_pixels(np.zeros((3, 3), np.float32), np.zeros((3, 4), bool))
    with pytest.raises(InvalidInputError, match="calibration must be a StereoCalibration"):
        group_obstacle_pixels(np.zeros((3, 3), np.float32), np.zeros((3, 3), bool), calibration={"focal_px": 700})
    with pytest.raises(InvalidInputError, match="cell_px"):
        GroupingParameters(cell_px=1)
    with pytest.raises(InvalidInputError, match="max_distance_m"):
        ObstacleParameters(max_distance_m=float("nan"))
    for field, bad in (("corridor_width_m", "1"), ("flat_tolerance_m", 0.0), ("distance_percentile", None),
                       ("min_standing_fraction", -0.1), ("distance_min_patch_pixels", np.int64(0)),
                       ("distance_neighbourhood_patches", -1), ("distance_neighbourhood_patches", 101),
                       ("distance_neighbourhood_patches", 1.0), ("scan_percentile", 100.5)):
        with pytest.raises(InvalidInputError, match=field):
            ObstacleParameters(**{field: bad})
    assert ObstacleParameters(max_distance_m=np.float32(12.5), corridor_width_m=2).max_distance_m == 12.5
    for bad in (0, 65, 16.5, True):
        with pytest.raises(InvalidInputError, match="distance_min_patch_pixels"):
            ObstacleParameters(distance_min_patch_pixels=bad)


def test_far_ground_raised_by_disparity_noise_does_not_stand():
    from stereo_obstacles.obstacles import standing_pixels

    h, w = RIG.height_px, RIG.width_px
    yy, xx = np.mgrid[0:h, 0:w]
    disparity = np.where(yy > RIG.cy_px, GROUND.disparity_at(xx, yy), np.nan).astype(np.float32)
    far, near = (yy == 124), (yy == 200)              # plane disparity 0.4 px (~105 m) and 8 px (~5 m)
    disparity[far] += 0.3                             # noise: 0.3 px is ~1 m of height at 105 m
    disparity[near] += 0.3                            # the same 0.3 px is ~5 cm there: flat
    everything = np.isfinite(disparity)
    loose = standing_pixels(everything, disparity, GROUND, RIG)
    strict = standing_pixels(everything, disparity, GROUND, RIG, min_excess_px=0.5)
    assert loose[far].all() and not strict[far].any()
    assert not loose[near].any() and not strict[near].any()
    disparity[near] += 2.0                            # 2.3 px above the plane at 5 m: ~35 cm, stands
    assert standing_pixels(everything, disparity, GROUND, RIG, min_excess_px=0.5)[near].all()


@pytest.mark.parametrize("calibration", [RIG, None])
def test_a_group_below_the_ground_plane_is_not_called_a_marking(calibration):
    """A scene the plane does not describe (no ground in view) leaves groups far under it."""
    scene = detection()
    ys, xs = np.mgrid[228:236, 225:300]
    disparity = np.full(scene.disparity.shape, np.nan, np.float32)
    disparity[ys, xs] = GROUND.disparity_at(xs, ys) - 5.0          # 5 px farther than the ground there
    groups = np.zeros(disparity.shape, np.int32)
    groups[ys, xs] = 1
    result = measure_obstacles(groups, disparity, calibration, GROUND)
    assert result.obstacles == () and len(result.rejected) == 1
    assert result.rejected[0].reason.startswith("below the fitted ground plane (at least ")
    assert "does not fit this part of the scene" in result.rejected[0].reason
