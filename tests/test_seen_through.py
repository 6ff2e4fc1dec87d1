"""Whether the background shows between two obstacles side by side in the image."""

from __future__ import annotations

import numpy as np
import pytest

from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.colour_split import ColourCue
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.seen_through import SeenThroughParameters, background_between

RIG = StereoCalibration(focal_px=350.0, cx_px=160.0, cy_px=120.0, baseline_m=0.12)   # f B = 42 px m
POLE, WALL = (128, 128), (150, 100)


def _scene(first_rows=slice(40, 200), second_rows=slice(40, 200), wall_rows=slice(40, 200)):
    """Two poles at 4.0 m (columns 100-111) and 4.2 m (124-135) with a wall at 8 m, of another
    colour, matched in the columns between them over ``wall_rows``; returns the arguments of
    :func:`background_between` but the parameters."""
    disparity = np.full((240, 320), np.nan, np.float32)
    chroma = np.full((240, 320, 2), 128, np.uint8)
    coloured = np.zeros((240, 320), bool)
    for rows, columns, z_m, colour in ((first_rows, slice(100, 112), 4.0, POLE), (second_rows, slice(124, 136), 4.2, POLE),
                                       (wall_rows, slice(112, 124), 8.0, WALL)):
        disparity[rows, columns] = RIG.focal_baseline_px_m / z_m
        chroma[rows, columns] = colour
        coloured[rows, columns] = True
    pieces = []
    for rows, columns in ((first_rows, slice(100, 112)), (second_rows, slice(124, 136))):
        ys, xs = np.mgrid[rows, columns]
        pieces.append((ys.ravel(), xs.ravel()))
    colours = (np.array(POLE, float), np.array(POLE, float))
    return pieces[0], pieces[1], disparity, ColourCue(chroma, coloured), colours, RIG, 0.3, 10.0


def test_a_wall_behind_two_poles_shows_between_them_in_either_order():
    first, second, *rest = _scene()
    assert background_between(first, second, *rest)
    assert background_between(second, first, *rest)


def test_how_many_rows_must_show_it():
    # the poles side by side over 160 rows, the wall matched in 40 of them (a quarter)
    args = _scene(wall_rows=slice(40, 80))
    assert background_between(*args)
    assert not background_between(*args, SeenThroughParameters(min_rows_fraction=0.3))
    assert not background_between(*args, SeenThroughParameters(min_rows=41))
    few = _scene(wall_rows=slice(40, 44))                       # 4 rows: fewer than 5
    assert not background_between(*few)
    assert background_between(*few, SeenThroughParameters(min_rows=4, min_rows_fraction=0.0))


def test_a_row_needs_matched_pixels_mostly_behind_both():
    first, second, disparity, cue, *rest = _scene()
    half = disparity.copy()
    half[:, 112:118] = RIG.focal_baseline_px_m / 4.1            # half of each row between them nearer
    assert background_between(first, second, half, cue, *rest)  # half is enough
    assert not background_between(first, second, half, cue, *rest, SeenThroughParameters(min_row_fraction=0.6))
    single = disparity.copy()
    single[:, 112:118] = single[:, 119:124] = np.nan           # one matched pixel a row between them
    assert not background_between(first, second, single, cue, *rest)
    assert background_between(first, second, single, cue, *rest, SeenThroughParameters(min_row_matched=1))


def test_pieces_one_above_the_other_or_overlapping_in_columns_are_not_side_by_side():
    # a pole above and below a nearer box: what lies between them is not beside them
    assert not background_between(*_scene(first_rows=slice(10, 60), second_rows=slice(100, 200)))
    first, second, *rest = _scene()
    overlapping = (second[0], second[1] - 20)                  # columns 104-115 against the first's 100-111
    assert not background_between(first, overlapping, *rest)
    touching = (second[0], second[1] - 12)                     # columns 112-123: nothing between them
    assert not background_between(first, touching, *rest)


def test_a_missing_disparity_at_a_facing_pixel_leaves_the_other():
    first, second, disparity, *rest = _scene()
    disparity[:, 111] = np.nan                                 # the first pole's last column unmatched
    assert background_between(first, second, disparity, *rest)


def test_ground_coloured_obstacles_ask_for_another_colour():
    # two poles phase 1 calls ground (grey concrete, say): pixels it calls ground between them are
    # no sign of background unless their colour differs
    first, second, disparity, cue, *rest = _scene()
    ground_everywhere = np.zeros_like(cue.coloured)
    own_colour = cue.chroma.copy()
    own_colour[:, 112:124] = POLE
    assert not background_between(first, second, disparity, ColourCue(own_colour, ground_everywhere), *rest)
    assert background_between(first, second, disparity, ColourCue(cue.chroma, ground_everywhere), *rest)
    # the same colour between two obstacle-coloured poles, called ground by phase 1: ground seen
    ground_between = cue.coloured.copy()
    ground_between[:, 112:124] = False
    assert background_between(first, second, disparity, ColourCue(own_colour, ground_between), *rest)


def test_bad_input_is_refused():
    first, second, disparity, cue, *rest = _scene()
    none = (np.zeros(0, np.int64), np.zeros(0, np.int64))
    with pytest.raises(InvalidInputError, match="at least one pixel"):
        background_between(first, none, disparity, cue, *rest)
    with pytest.raises(InvalidInputError, match="must be"):
        background_between(first, second, disparity[:100], cue, *rest)


def test_only_rows_holding_both_count():
    first, (ys, xs), *rest = _scene(second_rows=slice(40, 171))
    kept = (ys < 61) | (ys >= 150)                             # the second pole hidden in rows 61-149
    second = (ys[kept], xs[kept])                              # side by side in 42 rows
    assert background_between(first, second, *rest, SeenThroughParameters(min_rows=42, min_rows_fraction=1.0))
    assert not background_between(first, second, *rest, SeenThroughParameters(min_rows=43))


def test_bad_parameters_are_refused():
    for field, value in (("min_row_matched", 0), ("min_rows", 1.5), ("min_row_fraction", 1.1),
                         ("min_rows_fraction", -0.1)):
        with pytest.raises(InvalidInputError, match=field):
            SeenThroughParameters(**{field: value})
