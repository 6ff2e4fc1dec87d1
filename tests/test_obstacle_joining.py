"""Obstacles found in pieces, joined and measured as one."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.obstacle_joining import join_obstacles, measure_joined
from stereo_obstacles.obstacles import ObstacleParameters, measure_obstacles

RIG = StereoCalibration(focal_px=350.0, cx_px=160.0, cy_px=120.0, baseline_m=0.12)   # f B = 42 px m


def test_joined_sets_take_their_smallest_id():
    ids = np.array([[0, 1, 2, 3, 4, 5]], np.int32)
    np.testing.assert_array_equal(join_obstacles(ids, [(4, 2), (2, 5), (1, 3)]), [[0, 1, 2, 1, 2, 2]])
    np.testing.assert_array_equal(join_obstacles(ids, []), ids)


def _pieces():
    """A small near piece (group 1, 4.0 m), a large far piece of the same object (group 2, 4.4 m)
    and another object (group 3, 6.0 m), measured without a ground plane."""
    groups = np.zeros((120, 200), np.int32)
    disparity = np.full((120, 200), np.nan, np.float32)
    groups[0:16, 40:56], disparity[0:16, 40:56] = 1, 42 / 4.0
    groups[30:110, 40:120], disparity[30:110, 40:120] = 2, 42 / 4.4
    groups[30:60, 150:190], disparity[30:60, 150:190] = 3, 42 / 6.0
    return groups, disparity, measure_obstacles(groups, disparity, RIG, None, with_scan=False)


def test_joined_pieces_are_one_obstacle_measured_as_one():
    groups, disparity, pieces = _pieces()
    near, far, other = pieces.obstacles
    joined, obstacles = measure_joined(groups, pieces, [(far.id, near.id)], disparity, RIG, None)
    assert joined.dtype == np.int32 and joined[5, 45] == joined[50, 50] == 1 and joined[40, 160] == 3
    assert len(obstacles.obstacles) == 2 and obstacles.scan is None
    whole, unchanged = obstacles.obstacles
    assert whole.pixel_count == near.pixel_count + far.pixel_count
    assert unchanged == replace(other, id=2)
    # the near piece's 4 patches are under a twentieth of the union's 114: the 5th percentile of
    # the patch depths lies in the far piece, as it would for one group of those pixels. (The near
    # piece lies two patch rows above the far one: touching it, as it did until session 33, the
    # neighbourhood medians of the patches where the two meet lie between the pieces, and the
    # union read 4.365 m, no longer one piece's distance.)
    assert whole.distance_m == pytest.approx(4.4)
    assert whole == measure_obstacles(joined, disparity, RIG, None, with_scan=False).obstacles[0]


def test_a_slanted_face_in_two_pieces_is_read_on_the_plane_of_both():
    # a wall receding from 4 m (10.5 px, column 40) to 7 m (6 px, column 199), found as two pieces
    # each too little slanted (21 % and 27 % of their nearest disparity) to be read on its plane;
    # joined, the face spans 43 % and is read on its plane at its nearest patch (column 43.5)
    groups = np.zeros((140, 200), np.int32)
    disparity = np.full((140, 200), np.nan, np.float32)
    columns = np.arange(40, 200)[None, :]
    groups[20:100, 40:120], groups[20:100, 120:200] = 1, 2
    disparity[20:100, 40:200] = (10.5 - 4.5 * (columns - 40) / 159).astype(np.float32)
    pieces = measure_obstacles(groups, disparity, RIG, None, with_scan=False)
    near_piece = min(o.distance_m for o in pieces.obstacles)
    assert near_piece > 1.02 * RIG.focal_baseline_px_m / 10.5            # its percentile, behind
    _, obstacles = measure_joined(groups, pieces, [(1, 2)], disparity, RIG, None)
    assert obstacles.obstacles[0].distance_m == pytest.approx(
        RIG.focal_baseline_px_m / (10.5 - 4.5 * 3.5 / 159), rel=0.002)
    assert obstacles.obstacles[0].distance_m < near_piece


def test_a_joined_obstacle_is_never_farther_than_its_largest_piece():
    # a wall receding from 4 m to 7 m, measured on its plane at its near end, and a piece of it off
    # that plane: together they no longer lie on one plane, and the 5th percentile of their
    # patches lies well behind the wall's near end
    groups = np.zeros((140, 200), np.int32)
    disparity = np.full((140, 200), np.nan, np.float32)
    columns = np.arange(40, 200)[None, :]
    groups[20:100, 40:200], disparity[20:100, 40:200] = 1, (10.5 - 4.5 * (columns - 40) / 159).astype(np.float32)
    groups[104:136, 40:96], disparity[104:136, 40:96] = 2, 8.0
    pieces = measure_obstacles(groups, disparity, RIG, None, with_scan=False)
    wall = max(pieces.obstacles, key=lambda o: o.pixel_count)
    assert wall.distance_m == pytest.approx(4.0, abs=0.1)
    joined, obstacles = measure_joined(groups, pieces, [(1, 2)], disparity, RIG, None)
    as_one = measure_obstacles(joined, disparity, RIG, None, with_scan=False).obstacles[0]
    assert as_one.distance_m > 1.01 * wall.distance_m
    assert obstacles.obstacles[0].distance_m == wall.distance_m


def test_without_a_calibration_pieces_are_joined_in_pixels():
    groups, disparity, _ = _pieces()
    pieces = measure_obstacles(groups, disparity, None, None, with_scan=False)
    _, obstacles = measure_joined(groups, pieces, [(1, 2)], disparity, None, None)
    assert len(obstacles.obstacles) == 2 and obstacles.obstacles[0].distance_m is None


def test_a_joined_group_the_union_puts_beyond_the_distance_limit_stays_an_obstacle():
    # two faces receding to 7 m, each measured on its plane at its near end (3.69 and 3.95 m);
    # together they are no plane, and the union's 5th percentile (3.98 m) lies beyond the limit
    groups = np.zeros((140, 200), np.int32)
    disparity = np.full((140, 200), np.nan, np.float32)
    columns = np.arange(40, 200)[None, :]
    for group, rows, near_px in ((1, slice(20, 100), 10.75), (2, slice(104, 136), 11.5)):
        groups[rows, 40:200] = group
        disparity[rows, 40:200] = (near_px - (near_px - 6.0) * (columns - 40) / 159).astype(np.float32)
    params = ObstacleParameters(max_distance_m=3.97)
    pieces = measure_obstacles(groups, disparity, RIG, None, params, with_scan=False)
    assert [o.distance_m for o in pieces.obstacles] == pytest.approx([3.691, 3.945], abs=0.002)
    _, obstacles = measure_joined(groups, pieces, [(1, 2)], disparity, RIG, None, params)
    assert obstacles.rejected == () and obstacles.obstacles[0].distance_m == pytest.approx(3.945, abs=0.002)


def test_the_pieces_rejections_are_kept():
    groups, disparity, _ = _pieces()
    groups[115:120, 150:190], disparity[115:120, 150:190] = 4, 42 / 40.0      # 40 m: too far
    pieces = measure_obstacles(groups, disparity, RIG, None, with_scan=False)
    assert len(pieces.rejected) == 1
    _, obstacles = measure_joined(groups, pieces, [(1, 2)], disparity, RIG, None)
    assert obstacles.rejected == pieces.rejected


@pytest.mark.parametrize("pairs", [[(0, 1)], [(1, 9)]])
def test_pairs_of_ids_that_are_not_obstacles_are_refused(pairs):
    groups, disparity, pieces = _pieces()
    with pytest.raises(InvalidInputError, match="not ids of the pieces' obstacles"):
        measure_joined(groups, pieces, pairs, disparity, RIG, None)
