"""The free range per direction: sectors, nearest obstacle per sector, its percentile, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from _obstacle_scene import RIG, TRUE_DISTANCES_M, detection
from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.direction_scan import DirectionScan, direction_scan, sector_of_columns
from stereo_obstacles.errors import InvalidInputError

# 200 x 40 pixels, focal 500 px, optical axis at column 100: column u looks along atan((u - 100) / 500)
CAMERA = StereoCalibration(focal_px=500.0, cx_px=100.0, cy_px=20.0, baseline_m=0.1, width_px=200, height_px=40)


def _scene(boxes):
    """id_map and disparity with each ``(id, x0, x1, rows, disparity)`` box painted in order."""
    ids = np.zeros((40, 200), np.int32)
    d = np.full((40, 200), np.nan, np.float32)
    for obstacle_id, x0, x1, rows, disparity in boxes:
        ids[rows, x0:x1] = obstacle_id
        d[rows, x0:x1] = disparity
    return ids, d


def _range_m(column: int, disparity: float) -> float:
    z = CAMERA.focal_baseline_px_m / disparity
    return z * math.hypot(1.0, (column - CAMERA.cx_px) / CAMERA.focal_px)


def test_sectors_are_whole_multiples_of_their_width_and_follow_the_columns():
    sectors, first = sector_of_columns(200, CAMERA, 1.0)
    leftmost = math.degrees(math.atan2(-100, 500))              # -11.3 deg
    assert first == math.floor(leftmost) == -12
    assert sectors[0] == 0 and np.all(np.diff(sectors) >= 0)
    assert sectors[100] == 12                                    # the optical axis starts the sector [0, 1)
    assert sectors[99] == 11                                     # just left of it
    assert sectors[-1] == math.floor(math.degrees(math.atan2(99, 500)) - first)
    scan = direction_scan(*_scene([]), CAMERA, sector_deg=1.0, min_pixels=1, percentile=10.0)
    assert len(scan.ranges_m) == sectors[-1] + 1 and set(scan.ranges_m) == {None}
    assert scan.bearings_deg()[0] == pytest.approx(-11.5) and scan.bearings_deg()[12] == pytest.approx(0.5)


def test_one_box_gives_its_nearest_pixel_range_in_the_sectors_it_covers_and_none_elsewhere():
    ids, d = _scene([(1, 120, 140, slice(10, 30), 10.0)])        # 5 m ahead, 20 columns right of the axis
    scan = direction_scan(ids, d, CAMERA, sector_deg=90.0, min_pixels=1, percentile=0.0)
    assert scan.first_bearing_deg == -90.0 and len(scan.ranges_m) == 2
    assert scan.ranges_m == (None, round(_range_m(120, 10.0), 3)) and scan.obstacle_ids == (None, 1)
    fine = direction_scan(ids, d, CAMERA, sector_deg=1.0, min_pixels=1, percentile=0.0)
    lo, hi = (math.degrees(math.atan2(u - 100, 500)) for u in (120, 139))
    for bearing, rng, obstacle in zip(fine.bearings_deg(), fine.ranges_m, fine.obstacle_ids):
        covered = bearing + 0.5 > lo and bearing - 0.5 <= hi
        assert (rng is not None) == covered and (obstacle == 1) == covered
        if covered:
            assert _range_m(120, 10.0) - 1e-3 <= rng <= _range_m(139, 10.0) + 1e-3


def test_the_nearest_obstacle_with_enough_pixels_wins_a_sector():
    far = (1, 100, 140, slice(0, 40), 10.0)                      # 5 m
    near = (2, 110, 112, slice(0, 20), 20.0)                     # 2.5 m, 40 pixels
    scan = direction_scan(*_scene([far, near]), CAMERA, sector_deg=90.0, min_pixels=40, percentile=0.0)
    assert scan.obstacle_ids[1] == 2 and scan.ranges_m[1] == round(_range_m(110, 20.0), 3)
    scan = direction_scan(*_scene([far, near]), CAMERA, sector_deg=90.0, min_pixels=41, percentile=0.0)
    assert scan.obstacle_ids[1] == 1 and scan.ranges_m[1] == round(_range_m(100, 10.0), 3)


def test_the_range_is_numpys_percentile_of_the_obstacles_pixel_ranges_in_the_sector():
    rng = np.random.default_rng(3)
    ids, d = _scene([(1, 100, 140, slice(0, 40), 10.0)])
    d[ids == 1] = rng.uniform(8.0, 12.0, size=int((ids == 1).sum())).astype(np.float32)
    d[5, 105] = np.nan                                           # unmatched: left out
    for q in (0.0, 10.0, 37.5, 100.0):
        scan = direction_scan(ids, d, CAMERA, sector_deg=90.0, min_pixels=1, percentile=q)
        ys, xs = np.nonzero((ids == 1) & np.isfinite(d))
        ranges = CAMERA.focal_baseline_px_m / d[ys, xs].astype(np.float64) * np.hypot(1.0, (xs - 100) / 500)
        assert scan.ranges_m[1] == pytest.approx(np.percentile(ranges, q), abs=5e-4)


def test_the_obstacle_scan_takes_its_own_percentile_not_the_distances():
    from stereo_obstacles.obstacles import ObstacleParameters, obstacle_scan

    rng = np.random.default_rng(4)
    ids, d = _scene([(1, 100, 140, slice(0, 40), 10.0)])
    d[ids == 1] = rng.uniform(8.0, 12.0, size=int((ids == 1).sum())).astype(np.float32)
    params = ObstacleParameters(scan_sector_deg=90.0, scan_min_pixels=1, scan_percentile=37.5, distance_percentile=5.0)
    expected = direction_scan(ids, d, CAMERA, sector_deg=90.0, min_pixels=1, percentile=37.5)
    assert obstacle_scan(ids, d, CAMERA, params).ranges_m == expected.ranges_m
    assert ObstacleParameters().scan_percentile == 10.0


def test_pixels_without_a_depth_do_not_count():
    ids, d = _scene([(1, 120, 140, slice(0, 40), 10.0)])
    doffs = StereoCalibration(focal_px=500.0, cx_px=100.0, cy_px=20.0, baseline_m=0.1, doffs_px=-10.0)
    assert direction_scan(ids, d, doffs, sector_deg=90.0, min_pixels=1, percentile=0.0).ranges_m == (None, None)
    for missing in (np.nan, np.inf):                            # an infinite disparity is no depth either (not 0 m)
        d[:] = missing
        assert direction_scan(ids, d, CAMERA, sector_deg=90.0, min_pixels=1, percentile=0.0).ranges_m == (None, None)


def test_the_range_counts_doffs_as_the_depth_does():
    ids, d = _scene([(1, 120, 140, slice(0, 40), 10.0)])
    middlebury = StereoCalibration(focal_px=500.0, cx_px=100.0, cy_px=20.0, baseline_m=0.1, doffs_px=15.0)
    scan = direction_scan(ids, d, middlebury, sector_deg=90.0, min_pixels=1, percentile=0.0)
    assert scan.ranges_m[1] == round(50.0 / 25.0 * math.hypot(1.0, 20 / 500), 3)      # f B / (d + doffs) = 2 m


def test_any_obstacle_numbers_are_taken_and_given_back():
    for big in (7, 50_000_000, 2 ** 40):                      # the pipeline's 1..N, sparse numbers, beyond int32
        ids = np.zeros((40, 200), np.int64)
        ids[0:20, 120:140], ids[20:40, 120:140], ids[:, 0:10] = big, 3, -4      # negative: no obstacle
        d = np.full((40, 200), 10.0, np.float32)
        d[0:20, 120:140] = 20.0
        scan = direction_scan(ids, d, CAMERA, sector_deg=1.0, min_pixels=1, percentile=0.0)
        assert {i for i in scan.obstacle_ids if i is not None} == {big}
        narrow = direction_scan(ids, d, CAMERA, sector_deg=0.01, min_pixels=1, percentile=0.0)     # 0.11 deg a column
        assert narrow.obstacle_ids.count(big) == 20 and len(narrow.ranges_m) > 2000


def test_renumbered_maps_the_ids_and_keeps_the_ranges():
    scan = DirectionScan(sector_deg=1.0, first_bearing_deg=-2.0, field_of_view_deg=(-1.5, 0.5),
                         ranges_m=(None, 4.0, 5.0), obstacle_ids=(None, 1, 2))
    assert scan.renumbered(np.array([0, 7, 0])) == DirectionScan(1.0, -2.0, (-1.5, 0.5), (None, 4.0, 5.0),
                                                                 (None, 7, None))
    assert scan.renumbered(np.array([0, 7])).obstacle_ids == (None, 7, None)          # 2 is beyond the new numbers


def test_the_measured_obstacle_list_carries_a_scan_when_calibrated():
    scene = detection()
    assert scene.uncalibrated.scan is None
    scan = scene.calibrated.scan
    nearest = {o.id: o.distance_m for o in scene.calibrated.obstacles}
    seen = {i for i in scan.obstacle_ids if i is not None}
    assert seen == set(nearest)                                  # the box, the pole and the wall each lead somewhere
    for bearing, rng, obstacle in zip(scan.bearings_deg(), scan.ranges_m, scan.obstacle_ids):
        if obstacle is not None:                                 # faces square to the camera: range = z / cos(bearing)
            left, right = bearing - scan.sector_deg / 2, bearing + scan.sector_deg / 2
            inner = 0.0 if left <= 0 <= right else min(abs(left), abs(right))
            outer = max(abs(left), abs(right))
            assert nearest[obstacle] / math.cos(math.radians(inner)) - 0.01 <= rng
            assert rng <= nearest[obstacle] / math.cos(math.radians(outer)) + 0.01
    assert min(r for r in scan.ranges_m if r is not None) == pytest.approx(min(TRUE_DISTANCES_M), rel=0.02)


@pytest.mark.parametrize("kwargs, message", [
    ({"sector_deg": 0.0}, "sector_deg must be"), ({"sector_deg": float("nan")}, "sector_deg must be"),
    ({"sector_deg": 181.0}, "sector_deg must be"), ({"sector_deg": 1e-9}, "sector_deg must be"),
    ({"min_pixels": 0}, "min_pixels must be"), ({"min_pixels": 2.5}, "min_pixels must be"),
    ({"min_pixels": True}, "min_pixels must be"), ({"percentile": 101.0}, "percentile must lie"),
    ({"calibration": None}, "calibration must be a StereoCalibration"),
])
def test_bad_arguments_are_refused(kwargs, message):
    ids, d = _scene([])
    with pytest.raises(InvalidInputError, match=message):
        direction_scan(ids, d, **{"calibration": CAMERA, "sector_deg": 1.0, "min_pixels": 1, "percentile": 10.0,
                                  **kwargs})


@pytest.mark.parametrize("shapes", [((40, 200), (40, 10)), ((40, 0), (40, 0)), ((200,), (200,))])
def test_maps_of_other_shapes_or_without_columns_are_refused(shapes):
    with pytest.raises(InvalidInputError, match="same 2-D shape, with columns"):
        direction_scan(np.zeros(shapes[0], np.int32), np.zeros(shapes[1], np.float32), CAMERA, sector_deg=1.0,
                       min_pixels=1, percentile=10.0)


@pytest.mark.parametrize("change, message", [
    ({"ranges_m": (None,), "obstacle_ids": ()}, "one value per sector"),
    ({"ranges_m": (), "obstacle_ids": ()}, "at least one sector"),
    ({"field_of_view_deg": (-1.5, 0.5)}, "within the sectors"),                    # the sectors end at 0
    ({"ranges_m": [4.0, None], "obstacle_ids": [1, None]}, "must be tuples"),
    ({"ranges_m": (0.0, None)}, "ranges_m must be"), ({"ranges_m": (float("nan"), None)}, "ranges_m must be"),
    ({"ranges_m": ("4", None)}, "ranges_m must be"),
    ({"obstacle_ids": (0, None)}, "obstacle_ids must be"), ({"obstacle_ids": (1.5, None)}, "obstacle_ids must be"),
    ({"obstacle_ids": (None, 2)}, "obstacle_ids must be"),                     # an id without a range
    ({"sector_deg": 0.0}, "sector_deg must be"), ({"sector_deg": "1"}, "sector_deg must be"),
    ({"field_of_view_deg": (-3.0, 1.0)}, "field_of_view_deg"), ({"field_of_view_deg": (1.0, 0.0)}, "field_of_view_deg"),
    ({"first_bearing_deg": float("inf")}, "first_bearing_deg"),
])
def test_a_scan_that_cannot_be_is_refused(change, message):
    fields = {"sector_deg": 1.0, "first_bearing_deg": -2.0, "field_of_view_deg": (-1.5, -0.5),
              "ranges_m": (4.0, None), "obstacle_ids": (1, None), **change}
    with pytest.raises(InvalidInputError, match=message):
        DirectionScan(**fields)
