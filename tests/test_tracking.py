"""Obstacle tracking: stable ids, smoothed distances, approaching obstacles flagged."""

from __future__ import annotations

import numpy as np
import pytest

from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.obstacles import Obstacle
from stereo_obstacles.tracking import ObstacleTracker, TrackingParameters, box_iou_matrix

DT = 0.1


def seen(x: float, z: float, *, box=None, detection_id: int = 1, calibrated: bool = True) -> Obstacle:
    """An obstacle at lateral position ``x`` and distance ``z`` metres (box from a 350 px focal length)."""
    if box is None:
        u = int(160 + 350 * x / z)
        box = (u - 20, 100, u + 20, 200)
    return Obstacle(id=detection_id, box_px=box, pixel_count=400, disparity_px=42.0 / z, confidence=0.9,
                    distance_m=z if calibrated else None, centre_m=(x, 0.0, z) if calibrated else None)


def by_x(tracks, x):
    return next(t for t in tracks if t.obstacle is not None and t.obstacle.centre_m[0] == pytest.approx(x))


def test_ids_stay_with_their_obstacles_whatever_the_detection_order():
    rng = np.random.default_rng(3)
    tracker = ObstacleTracker()
    ids = {}
    for k in range(12):
        obstacles = [seen(-1.0, 4.0 - 0.1 * k, detection_id=1), seen(0.0, 6.0, detection_id=2),
                     seen(1.2, 9.0 + 0.05 * k, detection_id=3)]
        rng.shuffle(obstacles)           # detection numbers follow distance, not identity
        tracks = tracker.update(obstacles, k * DT)
        for x in (-1.0, 0.0, 1.2):
            ids.setdefault(x, set()).add(by_x(tracks, x).track_id)
    assert all(len(found) == 1 for found in ids.values())
    assert sorted(next(iter(found)) for found in ids.values()) == [1, 2, 3]


def test_approaching_obstacle_is_flagged_with_its_closing_speed_and_time_to_contact():
    tracker = ObstacleTracker()
    speed = 1.2                                    # m/s towards the camera
    for k in range(30):
        tracks = tracker.update([seen(0.0, 8.0 - speed * DT * k), seen(1.5, 5.0)], k * DT)
        if k == 0:
            assert not any(t.approaching for t in tracks)           # no warning from one frame
    moving, still = by_x(tracks, 0.0), by_x(tracks, 1.5)
    assert moving.approaching and not still.approaching
    assert moving.closing_speed_mps == pytest.approx(speed, rel=0.05)
    assert moving.time_to_contact_s == pytest.approx(moving.distance_m / moving.closing_speed_mps)
    assert moving.distance_m == pytest.approx(8.0 - speed * DT * 29, abs=0.05)
    assert still.closing_speed_mps == pytest.approx(0.0, abs=1e-9) and still.time_to_contact_s is None


def test_receding_obstacle_is_not_flagged():
    tracker = ObstacleTracker()
    for k in range(10):
        tracks = tracker.update([seen(0.0, 3.0 + 0.1 * k)], k * DT)
    assert not tracks[0].approaching and tracks[0].closing_speed_mps < 0


def test_smoothing_reduces_distance_noise():
    rng = np.random.default_rng(0)
    tracker = ObstacleTracker()
    measured, smoothed = [], []
    for k in range(200):
        z = 5.0 + rng.normal(0, 0.1)
        tracks = tracker.update([seen(0.0, z)], k * DT)
        measured.append(z)
        smoothed.append(tracks[0].distance_m)
    assert np.std(smoothed[20:]) < 0.7 * np.std(measured[20:])
    assert not any(t.approaching for t in tracks)


def test_missed_track_keeps_its_id_for_a_few_frames_then_ends():
    params = TrackingParameters(max_missed_frames=2)
    tracker = ObstacleTracker(params)
    for k in range(5):
        last = tracker.update([seen(0.0, 5.0 - 0.1 * k)], k * DT)[0]
    first = last.track_id
    missed = tracker.update([], 5 * DT)
    assert len(missed) == 1 and missed[0].obstacle is None and missed[0].missed_frames == 1
    assert missed[0].distance_m == pytest.approx(last.distance_m - last.closing_speed_mps * DT)  # predicted
    again = tracker.update([seen(0.0, 4.4)], 6 * DT)
    assert again[0].track_id == first and again[0].missed_frames == 0
    for k in (7, 8, 9):
        tracker.update([], k * DT)
    assert tracker.update([seen(0.0, 4.0)], 10 * DT)[0].track_id != first


def test_a_missed_track_predicted_past_the_camera_has_time_to_contact_zero():
    tracker = ObstacleTracker(TrackingParameters(max_missed_frames=5))
    for k in range(6):
        tracker.update([seen(0.0, 1.0 - 0.15 * k)], k * DT)        # 0.25 m away, closing at 1.5 m/s
    missed = tracker.update([], 8 * DT)[0]                           # predicted 0.35 m past it
    assert missed.obstacle is None and missed.approaching
    assert missed.distance_m == 0.0 and missed.time_to_contact_s == 0.0     # at contact, not -0.35 m


def test_far_jump_elsewhere_in_the_image_starts_a_new_track():
    tracker = ObstacleTracker()
    a = tracker.update([seen(0.0, 5.0)], 0.0)[0].track_id
    b = tracker.update([seen(0.0, 7.0, box=(10, 10, 40, 60))], DT)
    assert [t.track_id for t in b if t.obstacle is not None] != [a]


def test_merged_detection_keeps_the_id_through_box_overlap():
    tracker = ObstacleTracker()
    a = tracker.update([seen(0.0, 5.0, box=(100, 100, 140, 200))], 0.0)[0].track_id
    merged = seen(1.5, 5.0, box=(100, 100, 220, 200))       # centre 1.5 m away, box still overlapping
    assert tracker.update([merged], DT)[0].track_id == a


def test_overlapping_boxes_far_apart_in_distance_are_not_one_track():
    # a cut between two scenes: a tree's box at 28.9 m over a car's at 6.5 m made one track closing at
    # 670 m/s, its distance -4.7 m the next frame (user-level review, session 23)
    tracker = ObstacleTracker()
    tree = tracker.update([seen(0.0, 28.9, box=(100, 50, 160, 200))], 0.0)[0]
    car = tracker.update([seen(0.0, 6.5, box=(100, 60, 170, 200))], DT)
    assert [t.track_id for t in car if t.obstacle is not None] != [tree.track_id]
    assert all(t.distance_m >= 0 and abs(t.closing_speed_mps) < 1 for t in car)
    tracker = ObstacleTracker()                                 # a step within 30 % of the distance: kept
    first = tracker.update([seen(0.0, 5.0, box=(100, 100, 140, 200))], 0.0)[0]
    assert tracker.update([seen(0.8, 6.2, box=(100, 100, 150, 200))], DT)[0].track_id == first.track_id
    # and the track survives that one noisy frame: its velocity, started from it, predicts 7.4 m next
    later = [tracker.update([seen(0.0, 5.0, box=(100, 100, 140, 200))], k * DT)[0] for k in (2, 3)]
    assert [t.track_id for t in later] == [first.track_id] * 2


def test_without_calibration_boxes_carry_the_ids():
    tracker = ObstacleTracker()
    for k in range(5):
        tracks = tracker.update([seen(0, 1, box=(10 + 2 * k, 10, 50 + 2 * k, 60), calibrated=False),
                                 seen(0, 1, box=(100, 10, 140, 60), calibrated=False)], k * DT)
    assert [t.track_id for t in tracks] == [1, 2]
    assert all(t.distance_m is None and t.closing_speed_mps is None and not t.approaching for t in tracks)


def test_box_iou_matrix():
    a = np.array([[0, 0, 10, 10], [0, 0, 10, 10]])
    b = np.array([[0, 0, 10, 10], [10, 0, 20, 10], [5, 5, 15, 15]])
    np.testing.assert_allclose(box_iou_matrix(a, b), [[1.0, 0.0, 25 / 175]] * 2)
    assert box_iou_matrix(a, b[:0]).shape == (2, 0)


def test_errors():
    tracker = ObstacleTracker()
    tracker.update([], 1.0)
    with pytest.raises(InvalidInputError, match="time_s must increase"):
        tracker.update([], 1.0)
    with pytest.raises(InvalidInputError, match="finite"):
        tracker.update([], float("nan"))
    with pytest.raises(InvalidInputError, match="alpha"):
        TrackingParameters(alpha=0.0)
    with pytest.raises(InvalidInputError, match="max_missed_frames"):
        TrackingParameters(max_missed_frames=-1)
    for field, bad in (("min_iou", 1.5), ("min_iou", 0.0), ("beta", "0.1"), ("max_centre_jump_m", float("inf")),
                       ("min_closing_speed_mps", -1.0), ("min_age_frames", 2.0)):
        with pytest.raises(InvalidInputError, match=field):
            TrackingParameters(**{field: bad})


def test_the_tracker_takes_a_detections_list_and_refuses_what_it_cannot_use():
    # an ObstacleList gave "not iterable", time None a TypeError, a dict of options failed at the first
    # update; a new track's closing speed was -0.0 in the JSON lines (API review, session 23)
    from stereo_obstacles.obstacles import ObstacleList

    tracker = ObstacleTracker()
    listed = ObstacleList((seen(0.0, 5.0),), np.zeros((2, 2), np.int32))
    first = tracker.update(listed, 0.0)[0]
    assert first.track_id == 1 and str(first.closing_speed_mps) == "0.0"
    with pytest.raises(InvalidInputError, match="time_s must be a finite number of seconds, got None"):
        tracker.update([], None)
    with pytest.raises(InvalidInputError, match="params must be a TrackingParameters, got dict"):
        ObstacleTracker({"alpha": 0.3})
