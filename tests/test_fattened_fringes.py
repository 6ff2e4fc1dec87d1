"""An obstacle's fringe coloured like a farther obstacle beside it."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from _evaluation_scenes import comparison, evaluation_pair, true_obstacle
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.fattened_fringes import FringeParameters, fattened_fringes
from stereo_obstacles.obstacles import Obstacle, ObstacleList
from stereo_obstacles.pipeline import DetectionConfig

BROWN, BLUE, TAN = (150, 150), (128, 100), (150, 135)
"""Chroma ``(a* + 128, b* + 128)``: tan lies 15 from brown."""


def _box_with_a_strip(strip_columns=6, strip=BROWN, wall=BROWN, wall_disparity=8.0, strip_rows=40):
    """A blue box (columns 0-29, median disparity 12 px) whose last ``strip_columns`` columns, over
    ``strip_rows`` rows, are of the colour ``strip``, beside a wall of the colour ``wall``
    (columns 30-59, ``wall_disparity``): the obstacles and the chroma of a 40 x 60 image."""
    ids = np.zeros((40, 60), np.int32)
    ids[:, :30], ids[:, 30:] = 1, 2
    chroma = np.zeros((40, 60, 2), np.uint8)
    chroma[:, :30], chroma[:, 30:] = BLUE, wall
    chroma[:strip_rows, 30 - strip_columns:30] = strip
    obstacles = (Obstacle(1, (0, 0, 30, 40), 1200, 12.0, 1.0), Obstacle(2, (30, 0, 60, 40), 1200, wall_disparity, 1.0))
    return ObstacleList(obstacles=obstacles, id_map=ids), chroma


def _columns(fringe):
    return [int(column) for column in np.flatnonzero(fringe.any(axis=0))]


def test_a_strip_coloured_like_the_farther_wall_beside_it_is_its_fringe():
    obstacles, chroma = _box_with_a_strip()
    fringe = fattened_fringes(obstacles, chroma)
    assert np.array_equal(fringe, (obstacles.id_map == 1) & (chroma == BROWN).all(axis=2))
    assert _columns(fringe) == list(range(24, 30))


def test_only_the_pixels_within_band_px_of_the_farther_obstacle_are_its_fringe():
    """A strip 12 px wide: its pixels up to 8 px from the wall (OpenCV's exact distances: 1 px for
    the column beside it) are the fringe, the rest stays with the box."""
    obstacles, chroma = _box_with_a_strip(strip_columns=12)
    assert _columns(fattened_fringes(obstacles, chroma)) == list(range(22, 30))
    assert _columns(fattened_fringes(obstacles, chroma, FringeParameters(band_px=4))) == list(range(26, 30))


@pytest.mark.parametrize("wall_disparity, fringe", [(11.64, True), (11.65, False), (12.0, False)])
def test_the_other_obstacle_must_lie_min_step_rel_farther(wall_disparity, fringe):
    """3 % below the box's 12 px is 11.64 px: a wall at 11.65 px is not farther enough, and a
    strip of its colour beside it is a piece of the box's own."""
    obstacles, chroma = _box_with_a_strip(wall_disparity=wall_disparity)
    assert fattened_fringes(obstacles, chroma).any() == fringe


def test_a_strip_near_its_own_obstacle_s_colour_is_not_a_fringe():
    """The box tan, 15 from its brown strip: one object lit otherwise (the strip must lie 20 from
    its obstacle's median chroma)."""
    obstacles, chroma = _box_with_a_strip()
    chroma[:, :24] = TAN
    assert not fattened_fringes(obstacles, chroma).any()
    assert fattened_fringes(obstacles, chroma, FringeParameters(min_foreign_chroma=14.0)).any()


def test_a_strip_of_another_colour_than_the_wall_is_not_its_fringe():
    """A brown strip beside a tan wall, 15 apart (within ``max_same_chroma`` 10 they would be one
    colour)."""
    obstacles, chroma = _box_with_a_strip(wall=TAN)
    assert not fattened_fringes(obstacles, chroma).any()
    assert fattened_fringes(obstacles, chroma, FringeParameters(max_same_chroma=16.0)).any()


@pytest.mark.parametrize("strip_rows, fringe", [(5, True), (4, False)])
def test_a_fringe_is_a_piece_of_min_pixels(strip_rows, fringe):
    """A strip 6 columns wide: 5 rows are 30 pixels, a piece; 4 rows, 24, are not."""
    obstacles, chroma = _box_with_a_strip(strip_rows=strip_rows)
    assert fattened_fringes(obstacles, chroma).any() == fringe


def test_pieces_smaller_than_min_pixels_do_not_add_up():
    """Two strips of 4 rows, 6 rows apart: 48 pixels, but pieces of 24."""
    obstacles, chroma = _box_with_a_strip(strip_rows=4)
    chroma[10:14, 24:30] = BROWN
    assert not fattened_fringes(obstacles, chroma).any()
    chroma[4:10, 24:30] = BROWN
    assert fattened_fringes(obstacles, chroma).any()


@pytest.mark.parametrize("gap_columns, fringe", [(7, True), (8, False)])
def test_the_farther_obstacle_lies_within_band_px(gap_columns, fringe):
    """The wall moved right past ``gap_columns`` empty columns: the strip's last column lies
    ``gap_columns + 1`` px from it, within the 8 px band or not."""
    obstacles, chroma = _box_with_a_strip()
    ids = obstacles.id_map
    ids[:, 30:30 + gap_columns] = 0
    wall = replace(obstacles.obstacles[1], box_px=(30 + gap_columns, 0, 60, 40))
    obstacles = replace(obstacles, obstacles=(obstacles.obstacles[0], wall))
    assert fattened_fringes(obstacles, chroma).any() == fringe


def test_an_obstacle_is_not_its_own_farther_neighbour():
    """With no step asked for and a same-colour test wider than the foreign one (a brown strip is
    then both far from the box's blue and near it), the box alone must not lose the strip."""
    obstacles, chroma = _box_with_a_strip()
    alone = ObstacleList(obstacles=obstacles.obstacles[:1], id_map=np.where(obstacles.id_map == 1, 1, 0))
    params = FringeParameters(min_step_rel=0.0, max_same_chroma=100.0)
    assert not fattened_fringes(alone, chroma, params).any()


@pytest.mark.parametrize("ghost_disparity", [8.0, 20.0])
def test_an_obstacle_without_pixels_is_passed_over(ghost_disparity):
    """An obstacle listed but without pixels in the id map, as the farther one (8 px) or the
    nearer one (20 px): no median of no pixels (a warning, an error in the tests)."""
    obstacles, chroma = _box_with_a_strip()
    ghost = replace(obstacles.obstacles[1], id=3, disparity_px=ghost_disparity)
    with_ghost = replace(obstacles, obstacles=obstacles.obstacles + (ghost,))
    assert np.array_equal(fattened_fringes(with_ghost, chroma), fattened_fringes(obstacles, chroma))


def test_no_obstacles_no_fringe():
    obstacles = ObstacleList(obstacles=(), id_map=np.zeros((10, 10), np.int32))
    assert not fattened_fringes(obstacles, np.zeros((10, 10, 2), np.uint8)).any()


def test_chroma_of_another_shape_is_refused():
    obstacles, chroma = _box_with_a_strip()
    with pytest.raises(InvalidInputError, match="chroma"):
        fattened_fringes(obstacles, chroma[:, :59])
    with pytest.raises(InvalidInputError, match="uint8"):
        fattened_fringes(obstacles, chroma.astype(np.float32))


@pytest.mark.parametrize("field, value", [("min_foreign_chroma", -1.0), ("max_same_chroma", float("nan")),
                                          ("band_px", 0), ("band_px", 2.5), ("min_step_rel", 1.5),
                                          ("min_pixels", 0)])
def test_parameters_out_of_range_are_refused(field, value):
    with pytest.raises(InvalidInputError, match=field):
        FringeParameters(**{field: value})


def test_a_box_beside_a_wall_is_no_longer_read_at_the_wall_s_distance():
    """Scene 843 (session 37): a box at 7.15 m beside a nearer box at 4.82 m; 121 of its pixels,
    matched at the nearer box's disparity, were grouped with it, 68 formed an obstacle of their
    own, and the box, scored on the detection holding most of its pixels, read -32.4 %. Taken out
    of the nearer box, those 121 leave it to its own obstacle."""
    pair = evaluation_pair(843)
    box = true_obstacle(pair, "box", 7.15)
    kept, _ = comparison(pair, box, replace(DetectionConfig(), fattened_fringes=None))
    taken_out, _ = comparison(pair, box)
    assert kept.relative_error < -0.2
    assert abs(taken_out.relative_error) < 0.05
