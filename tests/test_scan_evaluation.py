"""The free range per direction against the truth: constructed sectors, then the built-in scene."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.direction_scan import DirectionScan
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.scan_evaluation import ScanComparison, compare_scan_with_truth, summarise_scans

CAMERA = StereoCalibration(focal_px=500.0, cx_px=100.0, cy_px=20.0, baseline_m=0.1, width_px=200, height_px=40)


def _range_m(column: int, depth_m: float) -> float:
    return depth_m * math.hypot(1.0, (column - CAMERA.cx_px) / CAMERA.focal_px)


def _world(low_step: bool = False):
    """A 1 m box 5 m ahead right of the axis (columns 120-139; 120-124 seen by the left camera
    only) and a 0.2 m kerb 2.5 m ahead left of it (columns 40-59); ``low_step``: a 0.2 m step
    3 m ahead in front of the box too (columns 150-169)."""
    instances = np.zeros((40, 200), np.uint8)
    disparity = np.full((40, 200), np.nan, np.float32)
    instances[10:30, 120:140], disparity[10:30, 120:140] = 1, CAMERA.focal_baseline_px_m / 5.0
    instances[30:34, 40:60], disparity[30:34, 40:60] = 2, CAMERA.focal_baseline_px_m / 2.5
    if low_step:
        instances[34:38, 150:170], disparity[34:38, 150:170] = 2, CAMERA.focal_baseline_px_m / 3.0
    seen_by_both = np.ones((40, 200), bool)
    seen_by_both[:, 120:125] = False
    truths = [SimpleNamespace(obstacle_id=1, size_m=(0.5, 0.5, 1.0)), SimpleNamespace(obstacle_id=2, size_m=(1, 1, 0.2))]
    return instances, disparity, seen_by_both, truths


VIEW_DEG = (math.degrees(math.atan2(-100, 500)), math.degrees(math.atan2(99, 500)))


def _scan(reported) -> DirectionScan:
    return DirectionScan(sector_deg=90.0, first_bearing_deg=-90.0, field_of_view_deg=VIEW_DEG, ranges_m=reported,
                         obstacle_ids=(None, None))


def _compare(reported):
    scan = _scan(reported)
    return compare_scan_with_truth(scan, *_world(), CAMERA, min_height_m=0.3, min_pixels=10)


def test_the_truth_is_the_nearest_tall_obstacle_both_cameras_see_and_the_nearest_of_any_seen():
    comparison = _compare((None, None))
    assert comparison.true_m == (None, round(_range_m(125, 5.0), 3))           # the kerb is too low to score
    assert comparison.nearest_seen_m == (round(_range_m(59, 2.5), 3), round(_range_m(120, 5.0), 3))
    for min_pixels, expected in ((300, comparison.true_m), (301, (None, None))):    # the box: 300 px seen by both
        assert compare_scan_with_truth(_scan((None, None)), *_world(), CAMERA, min_height_m=0.3,
                                       min_pixels=min_pixels).true_m == expected


def test_sectors_are_counted_found_overstated_and_understated():
    true_range = _range_m(125, 5.0)
    right = summarise_scans([_compare((None, true_range * 1.02))], max_distance_m=10.0)
    assert (right.n_sectors, right.n_with_obstacle, right.n_reported) == (2, 1, 1)
    assert right.median_abs_error_pct == pytest.approx(2.0, abs=0.01) and right.within_tolerance == 1.0
    assert (right.n_overstated, right.n_understated) == (0, 0)
    far = summarise_scans([_compare((None, true_range * 1.06)), _compare((None, None))], max_distance_m=10.0)
    assert (far.n_with_obstacle, far.n_reported, far.n_overstated) == (2, 1, 2) and far.within_tolerance == 0.0
    near = summarise_scans([_compare((2.0, true_range * 0.9))], max_distance_m=10.0)
    assert (near.n_overstated, near.n_understated) == (0, 2)                  # 2.0 m before the kerb at 2.5 m
    beyond = summarise_scans([_compare((None, None))], max_distance_m=4.0)
    assert (beyond.n_with_obstacle, beyond.n_overstated, beyond.median_abs_error_pct) == (0, 0, None)


def test_a_range_nearer_than_the_tall_obstacle_is_not_understated_when_something_lower_stands_there():
    scan = _scan((None, 4.0))
    with_step = compare_scan_with_truth(scan, *_world(low_step=True), CAMERA, min_height_m=0.3, min_pixels=10)
    assert with_step.true_m[1] > 5.0 and with_step.nearest_seen_m[1] < 3.1                # the box scores, the step is seen
    assert summarise_scans([with_step], max_distance_m=10.0).n_understated == 0
    assert summarise_scans([_compare((None, 4.0))], max_distance_m=10.0).n_understated == 1   # no step: 4 m is too near


def test_a_scan_of_other_images_is_refused():
    other = DirectionScan(sector_deg=90.0, first_bearing_deg=-180.0, field_of_view_deg=VIEW_DEG, ranges_m=(None,) * 3,
                          obstacle_ids=(None,) * 3)
    with pytest.raises(InvalidInputError, match="not measured on these images"):
        compare_scan_with_truth(other, *_world(), CAMERA, min_height_m=0.3, min_pixels=10)
    instances, disparity, seen_by_both, truths = _world()
    with pytest.raises(InvalidInputError, match="must have one shape"):
        compare_scan_with_truth(other, instances, disparity[:, :5], seen_by_both, truths, CAMERA, min_height_m=0.3,
                                min_pixels=10)


def test_the_built_in_scene_is_ranged_in_every_direction_it_has_an_obstacle():
    from stereo_obstacles.detection_evaluation import evaluate_synthetic_scene

    evaluation = evaluate_synthetic_scene(0)
    assert isinstance(evaluation.scan, ScanComparison) and len(evaluation.scan.reported_m) == 60
    summary = summarise_scans([evaluation.scan], max_distance_m=10.0)
    assert summary.n_with_obstacle >= 30 and summary.n_reported == summary.n_with_obstacle
    assert summary.n_overstated == 0 and summary.median_abs_error_pct < 1.0 and summary.within_tolerance > 0.9


def test_the_truth_counts_a_sector_by_the_scans_own_pixel_rule():
    from dataclasses import replace

    from stereo_obstacles.detection_evaluation import evaluate_synthetic_scene
    from stereo_obstacles.pipeline import DetectionConfig

    config = DetectionConfig()
    strict = replace(config, obstacles=replace(config.obstacles, scan_min_pixels=300))
    usual, fewer = (summarise_scans([evaluate_synthetic_scene(0, width_px=320, height_px=240, config=c).scan],
                                    max_distance_m=10.0) for c in (config, strict))
    assert 0 < fewer.n_with_obstacle < usual.n_with_obstacle and fewer.n_reported <= fewer.n_with_obstacle
    tall = summarise_scans([evaluate_synthetic_scene(0, width_px=320, height_px=240, min_height_m=2.0).scan],
                           max_distance_m=10.0)
    assert 0 < tall.n_with_obstacle < usual.n_with_obstacle                  # only the 2.4 m pole is 2 m high
