"""Splitting obstacle groups where two colours lie at two depths."""

from __future__ import annotations

import math
from dataclasses import replace

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from _evaluation_scenes import comparison, evaluation_pair, true_obstacle
from stereo_obstacles._colour_split_kernel import group_runs_kernel, one_per_block_kernel, two_colours_kernel
from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.colour_split import (HIDDEN_OBJECT_BEYOND_FRACTION, OBJECT_BEYOND_RIM_PX, RIM_PX, ColourCue,
                                          ColourSplitParameters, _distance_to_nearer, colour_cue,
                                          split_groups_by_colour)
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.footprints import close_points, footprint
from stereo_obstacles.obstacle_grouping import GroupingParameters, group_obstacle_pixels
from stereo_obstacles.part_boundaries import (HOLE_BRIDGE_PX, MAX_DECISION_PIXELS, PixelCanvas, distance_to_other,
                                              planes_near_boundary)


BROWN, BLUE, GREEN, GREY, SEA, TAN = (150, 150), (128, 100), (100, 150), (128, 128), (115, 105), (150, 135)
"""Chroma ``(a* + 128, b* + 128)``."""
MIN_OBJECT_PIXELS = 120
RIG = StereoCalibration(focal_px=350.0, cx_px=60.0, cy_px=40.0, baseline_m=0.12)
"""f B = 42 px m: disparity 7.0 is 6 m away."""


class Scene:
    """Disparity, chroma and one group, painted object by object (later ones in front)."""

    def __init__(self, shape=(80, 120)):
        self.d = np.full(shape, np.nan, np.float32)
        self.chroma = np.full(shape + (2,), 128, np.uint8)
        self.coloured = np.zeros(shape, bool)
        self.objects = np.full(shape, -1, np.int64)
        self.n = 0

    def paint(self, rows, columns, chroma, disparity, coloured=True):
        """Paint a rectangle; ``disparity`` is a number or a function of the columns."""
        xs = np.arange(self.d.shape[1], dtype=np.float32)[columns]
        self.d[rows, columns] = disparity(xs)[None, :] if callable(disparity) else disparity
        self.chroma[rows, columns] = chroma
        self.coloured[rows, columns] = coloured
        self.objects[rows, columns] = self.n
        self.n += 1
        return self

    def split(self, params=ColourSplitParameters(), calibration=None):
        groups = np.where(self.objects >= 0, 0, -1)
        return split_groups_by_colour(groups, self.d, ColourCue(self.chroma, self.coloured),
                                      min_object_pixels=MIN_OBJECT_PIXELS, params=params, calibration=calibration)


def _pole_before_box(shape=(80, 120), scale=1, gap_px=0.6):
    """A brown box (disparity 7.0) and a blue pole ``gap_px`` nearer standing in front of it."""
    s = scale
    return (Scene(shape).paint(slice(30 * s, 80 * s), slice(20 * s, 100 * s), BROWN, 7.0)
            .paint(slice(0, 80 * s), slice(53 * s, 67 * s), BLUE, 7.0 + gap_px))


def _same_parts(labels: np.ndarray, objects: np.ndarray) -> bool:
    """Whether ``labels`` group the painted pixels exactly as the objects do."""
    painted = objects >= 0
    pairs = set(zip(labels[painted].tolist(), objects[painted].tolist()))
    return len(pairs) == len({a for a, _ in pairs}) == len({b for _, b in pairs})


def test_a_pole_just_in_front_of_a_box_of_another_colour_is_split_off():
    scene = _pole_before_box()
    scene.d += np.random.default_rng(0).normal(0, 0.05, scene.d.shape).astype(np.float32)
    split = scene.split()
    assert split.max() == 1
    assert _same_parts(split, scene.objects)
    np.testing.assert_array_equal(split < 0, scene.objects < 0)


def test_nothing_is_split_without_a_second_colour_and_the_groups_come_back_as_they_are():
    scene = _pole_before_box()
    scene.chroma[:] = BROWN
    groups = np.where(scene.objects >= 0, 0, -1)
    cue = ColourCue(scene.chroma, scene.coloured)
    assert split_groups_by_colour(groups, scene.d, cue, min_object_pixels=MIN_OBJECT_PIXELS) is groups
    narrow = split_groups_by_colour(groups.astype(np.int32), scene.d, cue, min_object_pixels=MIN_OBJECT_PIXELS)
    assert narrow.dtype == np.int64 and np.array_equal(narrow, groups)


def test_nothing_is_split_when_the_two_colours_lie_at_one_depth():
    scene = _pole_before_box()
    scene.d[scene.objects >= 0] = 7.0
    assert scene.split().max() == 0


@pytest.mark.parametrize("gap_px", [0.25, 0.35])
def test_the_depth_gap_must_exceed_min_gap_px(gap_px):
    scene = _pole_before_box()
    scene.d[scene.objects == 1] = 7.0 + gap_px
    assert scene.split().max() == (1 if gap_px > 0.3 else 0)


@pytest.mark.parametrize("gap_px", [0.5, 0.7])
def test_near_objects_need_a_gap_of_min_gap_rel_of_their_disparity(gap_px):
    """At 20 px the gap is 3 % of it, 0.6 px: 0.5 px is not enough there."""
    scene = _pole_before_box()
    scene.d[scene.objects == 0] = 20.0
    scene.d[scene.objects == 1] = 20.0 + gap_px
    assert scene.split().max() == (1 if gap_px > 0.6 else 0)


def test_a_colour_boundary_across_one_slanted_surface_is_not_a_step():
    """Half a wall painted blue: the halves' medians differ by 1.2 px, but their planes meet."""
    slant = lambda xs: 10.0 + 0.02 * xs                                  # noqa: E731
    scene = Scene().paint(slice(10, 70), slice(0, 60), BROWN, slant).paint(slice(10, 70), slice(60, 120), BLUE, slant)
    assert scene.split().max() == 0


def test_two_faces_of_a_box_meeting_at_a_crease_are_not_split():
    scene = (Scene().paint(slice(10, 70), slice(20, 70), BROWN, 12.0)
             .paint(slice(10, 70), slice(70, 100), GREEN, lambda xs: 12.0 - 0.05 * (xs - 69.5)))
    assert scene.split().max() == 0


@pytest.mark.parametrize("scale", [1, 4])
def test_two_faces_of_a_large_box_meeting_at_a_crease_are_not_split_either(scale):
    """Decided on squares of 4 x 4 pixels, the boundary still reaches the next square."""
    s = scale
    side = lambda xs: 12.0 - 0.05 / s * (xs - 70 * s)                      # noqa: E731
    scene = (Scene((80 * s, 120 * s)).paint(slice(10 * s, 70 * s), slice(20 * s, 70 * s), BROWN, 12.0)
             .paint(slice(10 * s, 70 * s), slice(70 * s, 100 * s), GREEN, side))
    assert math.ceil(math.sqrt(np.count_nonzero(scene.objects >= 0) / MAX_DECISION_PIXELS)) == (4 if s > 1 else 1)
    assert scene.split().max() == 0


def test_the_planes_are_fitted_away_from_the_blurred_boundary():
    """A green panel 1 px behind the wall it rises from, the matching's blur spreading over 7 rows
    on each side of their boundary: fitted to all its rows, the short panel's plane would slant
    into the wall's there and read as a crease."""
    scene = (Scene((100, 160)).paint(slice(26, 40), slice(40, 120), GREEN, 7.0)
             .paint(slice(40, 90), slice(10, 150), BROWN, 8.0))
    scene.d[33:40, 40:120] = np.linspace(7.0, 7.9, 7)[:, None]
    scene.d[40:47, 10:150] = np.linspace(7.1, 8.0, 7)[:, None]
    split = scene.split()
    assert split.max() == 1
    panel, wall = (np.bincount(split[scene.objects == obj], minlength=2) for obj in (0, 1))
    assert panel.argmax() != wall.argmax()                      # blurred rows go to the nearer plane
    assert panel.max() >= 0.8 * panel.sum() and wall.max() >= 0.9 * wall.sum()


def _panel_before_a_two_faced_box(panel_d, noise=0.0):
    """A brown box showing two faces, its side face receding from 7.0 to 5.0 px over 40 columns
    left of its front face (7.0 px, 40 columns), and a blue panel ``panel_d`` over the front face's
    upper right corner: the boundary between them is an L. Fitted across both faces, the box's
    plane leans towards the panel's disparity (the step reads 0.1 px at 7.6)."""
    side = lambda xs: 5.0 + 2.0 * (xs - 10) / 40                       # noqa: E731
    scene = (Scene((90, 160)).paint(slice(30, 90), slice(10, 50), BROWN, side)
             .paint(slice(30, 90), slice(50, 90), BROWN, 7.0).paint(slice(10, 60), slice(60, 90), BLUE, panel_d))
    scene.d += np.random.default_rng(0).normal(0, noise, scene.d.shape).astype(np.float32)
    return scene, np.where(scene.objects == 1, 0, scene.objects)


@pytest.mark.parametrize("noise", [0.0, 0.05])
def test_a_step_hidden_by_the_lean_of_a_two_faced_box_is_read_near_the_boundary(noise):
    scene, objects = _panel_before_a_two_faced_box(7.6, noise)
    split = scene.split()
    assert split.max() == 1 and _same_parts(split, objects)


def test_near_the_boundary_the_step_must_exceed_one_and_a_half_gaps():
    """A panel 0.4 px in front: the near planes lie 0.33 px apart along the boundary (the box's
    band, an L, takes in some of its side face), more than the gap (0.3 px) but not 1.5 times it."""
    scene, _ = _panel_before_a_two_faced_box(7.4)
    assert scene.split().max() == 0


def test_the_near_band_leaves_out_the_blurred_pixels_at_the_boundary():
    """The matching blurs the step over about 8 px (a 9 x 9 mean here, within the group): a band
    reaching into the blur reads the step 0.36 px, under 1.5 gaps; from 8 px out, 0.54 px."""
    scene, objects = _panel_before_a_two_faced_box(7.6)
    inside = (objects >= 0).astype(np.float32)
    summed = cv2.blur(np.where(inside > 0, scene.d, 0).astype(np.float32), (9, 9))
    scene.d = np.where(inside > 0, summed / np.maximum(cv2.blur(inside, (9, 9)), 1e-6), np.nan).astype(np.float32)
    split = scene.split()
    assert split.max() == 1
    assert np.mean(split[objects == 2] == split[40, 75]) > 0.95 and np.mean(split[objects == 0] == split[80, 20]) > 0.95


def test_a_band_too_thin_to_pin_a_plane_down_keeps_the_plane_fitted_farther_out():
    """A pole 12 columns wide above a wall that also passes left of it, 10 columns away: the
    pole's band spans 11 columns and keeps the plane given, the wall's band (an L around the
    pole) is fitted."""
    ys, xs = np.mgrid[0:60, 0:80]
    pole = (xs >= 60) & (xs < 72) & (ys < 30)
    wall = (xs < 50) | (ys >= 40)
    keep = (pole | wall).ravel()
    canvas, _, _ = PixelCanvas.of_pixels(ys.ravel()[keep].astype(np.int64), xs.ravel()[keep].astype(np.int64))
    second = pole[canvas.ys, canvas.xs]
    d = np.where(second, 8.0 + 0.01 * canvas.ys, 7.0 + 0.02 * canvas.xs)
    given = ((0.0, 0.0, 1.0), (0.0, 0.0, 2.0))
    near = planes_near_boundary(canvas, d, second, distance_to_other(canvas, second), given)
    assert near[1] == given[1]
    np.testing.assert_allclose(near[0], (0.02, 0.0, 7.0), atol=1e-9)


def _near_planes_of(first, second_pixels, d_first, given):
    """:func:`planes_near_boundary` of a first part at the pixels ``first`` (rows, columns) with
    disparities ``d_first`` and a second part at 7.0 px at ``second_pixels``."""
    ys = np.concatenate([first[0], second_pixels[0]]).astype(np.int64)
    xs = np.concatenate([first[1], second_pixels[1]]).astype(np.int64)
    canvas, chosen, _ = PixelCanvas.of_pixels(ys, xs)
    second = chosen >= len(first[0])
    d = np.concatenate([d_first, np.full(len(second_pixels[0]), 7.0)])[chosen]
    return planes_near_boundary(canvas, d, second, distance_to_other(canvas, second), given)


def test_a_part_without_a_band_keeps_the_plane_fitted_farther_out():
    """A pole 12 columns wide between two walls: every pixel of it lies within 8 px of them."""
    ys, xs = np.mgrid[0:40, 0:60]
    pole = (xs >= 24) & (xs < 36)
    given = ((0.0, 0.0, 1.0), (0.0, 0.0, 2.0))
    near = _near_planes_of((ys[pole], xs[pole]), (ys[~pole], xs[~pole]), np.full(pole.sum(), 8.0), given)
    assert near[0] == given[0]


def test_a_band_whose_robust_plane_fails_keeps_the_plane_fitted_farther_out():
    """An L of 32 pixels 11-16 px from a square, spanning 26 px each way, 3 of them wild: the
    robust fit keeps 29, fewer than it needs."""
    rows = np.r_[np.full(16, 30), np.arange(4, 20)]
    columns = np.r_[np.arange(4, 20), np.full(16, 30)]
    d_first = np.full(32, 8.0)
    d_first[[0, 10, 20]] = 20.0
    square_rows, square_columns = np.mgrid[0:20, 0:20]
    given = ((0.0, 0.0, 1.0), (0.0, 0.0, 2.0))
    near = _near_planes_of((rows, columns), (square_rows.ravel(), square_columns.ravel()), d_first, given)
    assert near[0] == given[0]


def test_a_rim_around_an_object_is_not_split_off():
    """Sky-coloured pixels matched 1 px farther in a 3 px ring around a box (the matching's halo)."""
    scene = Scene().paint(slice(17, 63), slice(37, 83), BLUE, 8.0).paint(slice(20, 60), slice(40, 80), BROWN, 9.0)
    assert scene.split().max() == 0


@pytest.mark.parametrize("pole_d, split", [(7.6, True), (6.4, False)])
def test_a_thin_part_is_split_off_when_it_is_in_front_not_behind(pole_d, split):
    """A pole 12 px wide within the rows of a box: 8 of its 12 columns lie within 4 px of the box,
    and none more than 6 px away. In front (session 23: seed 182's pole was kept in a box 0.44 px
    behind it) it is an object; behind, it would be the halo of the box."""
    scene = (Scene().paint(slice(30, 80), slice(20, 100), BROWN, 7.0)
             .paint(slice(30, 80), slice(54, 66), BLUE, pole_d))
    assert bool(scene.split().max() == 1) == split
    if split:
        assert _same_parts(scene.split(), scene.objects)


@pytest.mark.parametrize("rows, split", [(slice(30, 76), True), (slice(30, 75), False)])
def test_a_farther_part_that_holds_an_object_beyond_its_rim_is_split_off(rows, split):
    """A tan part 15 px wide behind a brown box (15 apart in chroma: a face of the box lit
    otherwise, not a partly hidden object), within its columns and reaching down into it: 57 % of
    its pixels lie within 4 px of the box, but those more than 6 px away (OpenCV's distances: 7
    steps of 0.955 px; its 3 middle columns, down to 7 rows above the box) are 3 x 40 = 120 pixels,
    an object's count, with 46 rows, and it is an object (session 34: a box at 7.2 m, half of it
    within 4 px of the end of a wall in front, read -24 % merged with the wall); with 45 rows they
    are 117, too few, and it is a rim."""
    scene = (Scene().paint(slice(30, 80), slice(20, 100), BROWN, 7.0)
             .paint(rows, slice(52, 67), TAN, 6.4))
    farther = scene.objects == 1
    height = rows.stop - rows.start
    assert np.count_nonzero(farther) == 15 * height
    assert (3 * (height - 6) >= MIN_OBJECT_PIXELS) == split             # the docstring's count against the code's
    assert bool(scene.split().max() == 1) == split
    if split:
        assert _same_parts(scene.split(), scene.objects)


@pytest.mark.parametrize("rows, split", [(slice(20, 88), True), (slice(20, 84), False)])
def test_beyond_the_rim_a_large_group_counts_pixels_not_squares(rows, split):
    """Decided on squares of 2 x 2 px: a tan part 7 squares wide behind a brown box has its middle
    column of squares more than 6 px from the box (4 steps of 1.91 px), down to 4 squares above it:
    31 squares, 124 pixels, with 34 rows of squares; 29 squares, 116 pixels, with 32 (in squares
    either is far below an object's count)."""
    scene = (Scene((160, 240)).paint(slice(20, 140), slice(20, 220), BROWN, 7.0)
             .paint(rows, slice(110, 124), TAN, 6.4))
    assert math.ceil(math.sqrt(np.count_nonzero(scene.objects >= 0) / MAX_DECISION_PIXELS)) == 2
    square_rows = (rows.stop - rows.start) // 2
    assert (4 * (square_rows - 3) >= MIN_OBJECT_PIXELS) == split
    assert bool(scene.split().max() == 1) == split


@pytest.mark.parametrize("squares, split", [(4, True), (3, False)])
def test_beyond_the_rim_of_a_large_group_lies_one_and_a_half_squares_away(squares, split):
    """Decided on squares of 3 x 3 px: a tan ring one square wide behind a brown box, with a tab 5
    squares wide reaching ``squares`` squares out of it. Its squares 3 steps of 2.87 px from the
    box (8.6 px) lie beyond one and a half squares (4.5 px, so 6 px): with 4 squares, 3 rows of 5
    squares, 135 pixels, an object's count; with 3, 90 pixels, too few. (Beyond 3 squares instead,
    the 4 squares would give 90 too.)"""
    scene = (Scene((260, 330)).paint(slice(57 - 3 * squares, 57), slice(150, 165), TAN, 6.4)
             .paint(slice(57, 213), slice(42, 288), TAN, 6.4))
    scene.objects[scene.objects >= 0], scene.n = 0, 1                       # the tab and the ring: one part
    scene.paint(slice(60, 210), slice(45, 285), BROWN, 7.0)
    assert math.ceil(math.sqrt(np.count_nonzero(scene.objects >= 0) / MAX_DECISION_PIXELS)) == 3
    assert bool(scene.split().max() == 1) == split


@pytest.mark.parametrize("width, split", [(6, False), (7, True)])
def test_a_halo_up_to_6_px_wide_is_a_rim(width, split):
    """A blue ring ``width`` pixels wide 1 px behind a 40 x 40 box: 6 px wide, all its pixels but
    64 in its corners lie within 6 px of the box, and those are four pieces of 16, none a quarter
    of an object's count, as a partly hidden object's would be; 7 px wide, 276 lie beyond (its
    outer layer and more of its corners), an object's count, while 51 % of it still lies within
    4 px."""
    w = width
    scene = (Scene().paint(slice(20 - w, 60 + w), slice(40 - w, 80 + w), BLUE, 8.0)
             .paint(slice(20, 60), slice(40, 80), BROWN, 9.0))
    assert bool(scene.split().max() == 1) == split


def _pole_beside_a_wall_end(top, pole_colour):
    """A brown wall (disparity 7.6) and a pole of ``pole_colour`` 5 px wide 0.6 px behind it at its
    right end, from row ``top`` down."""
    return (Scene().paint(slice(30, 80), slice(20, 70), BROWN, 7.6)
            .paint(slice(top, 80), slice(70, 75), pole_colour, 7.0))


@pytest.mark.parametrize("top, pole_colour, ground_coloured_rows, split",
                         [(12, BLUE, 0, True), (22, BLUE, 0, False), (12, TAN, 0, False), (12, BLUE, 17, False)])
def test_a_partly_hidden_object_beside_a_nearer_one_is_no_rim(top, pole_colour, ground_coloured_rows, split):
    """Session 37: a pole at 9.1 m beside the end of a wall at 8.6 m read -6.8 %, merged with the
    wall. Here the pole's 4 columns next to the wall lie within 4 px of it (208 of its 340 pixels),
    and only 70 pixels of its top more than 6 px away, too few for an object beyond a rim; yet it
    is split off as a partly hidden object, obstacle-coloured, 55 from the wall in chroma, and
    those 70 pixels one piece. Not when only 20 pixels lie beyond (from row 22: fewer than a
    quarter of an object's), when its colour lies 15 from the wall's (tan: a face of the wall lit
    otherwise), or when its top 17 rows (25 %) are ground-coloured."""
    scene = _pole_beside_a_wall_end(top, pole_colour)
    scene.coloured[:top + ground_coloured_rows] &= scene.objects[:top + ground_coloured_rows] != 1
    parts = scene.split()
    assert bool(parts.max() == 1) == split
    if split:
        assert _same_parts(parts, scene.objects)


def _ringed_box(ring, far_colour=BROWN):
    """A box of ``far_colour`` (16 x 16 px, disparity 7.0) above a nearer blue box (8.3), with a
    3 px ring of ``ring`` on its other sides matched at its disparity."""
    return (Scene().paint(slice(27, 46), slice(47, 69), ring, 7.0)
            .paint(slice(30, 46), slice(50, 66), far_colour, 7.0)
            .paint(slice(46, 80), slice(20, 100), BLUE, 8.3))


@pytest.mark.parametrize("ring, split", [(SEA, True), (BLUE, False)])
def test_a_far_object_ringed_by_its_halo_is_no_rim(ring, split):
    """Session 36: a box 1.3 m behind another, the sea around it clustered with the nearer box by
    colour. Measured to the whole blue part, 75 % of the brown box lies within 4 px and 16 pixels
    beyond 6 px: a rim, and too little beyond it for a partly hidden object. A ring of sea (14
    from the blue in chroma) is the brown box's halo and is not counted as the blue part: then
    only the brown box's bottom 4 rows (25 %) lie within 4 px, and it is split off. A ring of the
    blue box's own colour is its receding flank and counts."""
    assert 16 < HIDDEN_OBJECT_BEYOND_FRACTION * MIN_OBJECT_PIXELS
    scene = _ringed_box(ring)
    brown = scene.objects == 1
    parts = scene.split()
    assert bool(parts.max() == 1) == split
    if split:
        assert len(np.unique(parts[brown])) == 1 and parts[70, 60] != parts[brown][0]
        assert np.count_nonzero(parts == parts[brown][0]) <= np.count_nonzero(brown) + 3 * 22 + 2 * 3 * 16


@pytest.mark.parametrize("far_colour, ring, ring_d, near_d, measured_past_the_ring",
                         [(BROWN, SEA, 7.2, 8.3, True), (BLUE, SEA, 7.2, 8.3, False), (BROWN, BROWN, 7.2, 8.3, False),
                          (BROWN, SEA, 7.5, 8.3, False), (BROWN, SEA, 7.2, 7.4, False)])
def test_the_ring_is_left_out_only_where_three_colours_meet_at_two_depths(far_colour, ring, ring_d, near_d,
                                                                          measured_past_the_ring):
    """The rim test's distances on the ringed box (the farther part at 7.0 px): past the ring when
    the farther part, the ring and the nearer part are three colours and the ring lies no more
    than the gap (0.3 px) in front of the farther part and at least the gap behind the nearer
    part. Otherwise they are measured to the whole nearer part: with a farther part of the nearer
    part's own colour (held-out scene 1133: a near cylinder's flank, split off as a farther part
    of the cylinder's colour, the pixels between 16 from both in chroma); with a ring of the
    farther part's colour; with the ring 0.5 px in front of the farther part; with the nearer part
    at 7.4 px, only 0.2 px in front of the ring."""
    scene = _ringed_box(ring, far_colour)
    scene.d[scene.objects == 0] = ring_d
    scene.d[scene.objects == 2] = near_d
    ys, xs = np.nonzero(scene.objects >= 0)
    canvas, _, _ = PixelCanvas.of_pixels(ys, xs)
    assert canvas.block == 1
    farther = scene.objects[ys, xs] == 1
    to_other = distance_to_other(canvas, farther)
    d = scene.d[ys, xs].astype(np.float64)
    distances = _distance_to_nearer(canvas, d, farther, 7.0, float(np.median(d[~farther])), scene.chroma[ys, xs],
                                    to_other, 0.3, ColourSplitParameters())
    top_of_the_box = farther & (ys == 30)
    assert (to_other[top_of_the_box] <= RIM_PX).all()
    if measured_past_the_ring:
        assert (distances[top_of_the_box] > OBJECT_BEYOND_RIM_PX).all()
    else:
        assert np.array_equal(distances, to_other)


def test_a_ring_is_not_left_out_of_a_part_of_phase_one_s_verdict():
    """A brown box ringed by ground-coloured green above a ground-coloured grey box: no two chroma
    clusters (only the brown is obstacle-coloured), so the parts are phase 1's verdict, whose
    ground-coloured part holds ground at any depth; its ring stays in it and the brown box is a
    rim (with the ring left out, as for chroma clusters, it would be split off: 5 more repeated
    detections over scenes 0..959, 9 over the five synthetic sets, session 36)."""
    scene = (Scene().paint(slice(27, 50), slice(47, 73), GREEN, 7.0, coloured=False)
             .paint(slice(30, 50), slice(50, 70), BROWN, 7.0)
             .paint(slice(50, 80), slice(20, 100), GREY, 8.3, coloured=False))
    assert scene.split().max() == 0


def test_pieces_apart_in_the_image_need_no_step_where_they_touch():
    scene = Scene().paint(slice(10, 70), slice(0, 40), BROWN, 7.0).paint(slice(10, 70), slice(80, 120), BLUE, 7.5)
    split = scene.split()
    assert split.max() == 1 and _same_parts(split, scene.objects)


def test_a_part_that_is_not_one_surface_is_not_split_off():
    """Two fifths of the blue part's pixels lie 1.5 px behind the rest (a colour boundary that
    runs across another surface): 57 % of the part lies on one plane, as ``on_plane_fraction``
    counts it, less than ``min_plane_fraction``. With three eighths behind, 62 % lies on it, and
    the part is split off: the default lies between the two."""
    def split_with_behind(period: int, behind_per_period: int, params=ColourSplitParameters()) -> int:
        scene = _pole_before_box()
        diagonal = np.add.outer(np.arange(80), np.arange(120)) % period
        scene.d[(scene.objects == 1) & (diagonal < behind_per_period)] = 9.1
        return int(scene.split(params).max())

    assert split_with_behind(15, 6) == 0
    assert split_with_behind(15, 6, replace(ColourSplitParameters(), min_plane_fraction=0.55)) == 1
    assert split_with_behind(8, 3) == 1


def test_pixels_near_the_boundary_go_to_the_part_whose_plane_they_fit():
    """The pole's outer columns took the box's colour (the blurred chroma): their disparity puts
    them back on the pole."""
    scene = Scene().paint(slice(30, 80), slice(10, 110), BROWN, 7.0).paint(slice(0, 80), slice(50, 74), BLUE, 7.6)
    scene.chroma[:, [50, 51, 72, 73]] = BROWN
    split = scene.split()
    assert split.max() == 1 and _same_parts(split, scene.objects)


def test_a_large_part_made_of_specks_is_not_an_object():
    """Blue specks of 2 x 2 pixels on the box (texture), none of an object's size: they stay with
    the box, and the blue pole alone is split off."""
    scene = _pole_before_box()
    specks = np.zeros(scene.d.shape, bool)
    specks[32::6, 22:50:6] = specks[33::6, 23:51:6] = True
    specks[32::6, 23:51:6] = specks[33::6, 22:50:6] = True
    scene.chroma[specks] = BLUE
    split = scene.split()
    assert split.max() == 1 and _same_parts(split, scene.objects)


def _blobs(shape, rows, columns, blob_px, hole_px):
    """``bool shape``: square blobs of ``blob_px`` pixels a side, ``hole_px`` apart, over ``rows`` x
    ``columns``: the matches of a sparsely matched face."""
    blobs = np.zeros(shape, bool)
    step = blob_px + hole_px
    for y in range(rows.start, rows.stop - blob_px + 1, step):
        for x in range(columns.start, columns.stop - blob_px + 1, step):
            blobs[y:y + blob_px, x:x + blob_px] = True
    return blobs


@pytest.mark.parametrize("hole_px, each_small", [(2, False), (6, False), (8, True)])
def test_blobs_a_few_unmatched_pixels_apart_are_one_piece(hole_px, each_small):
    """Sixteen 4 x 4 blobs (16 pixels each, 256 in all) are one piece of an object's size when the
    holes between them are at most twice ``HOLE_BRIDGE_PX`` (3) wide, and sixteen small ones when
    wider."""
    assert HOLE_BRIDGE_PX == 3.0
    blobs = _blobs((80, 120), slice(0, 4 * (4 + hole_px)), slice(0, 4 * (4 + hole_px)), 4, hole_px)
    ys, xs = np.nonzero(blobs)
    canvas, _, _ = PixelCanvas.of_pixels(ys, xs)
    small = canvas.small_pieces(np.ones(len(ys), bool), MIN_OBJECT_PIXELS)
    assert np.count_nonzero(blobs) == 256
    assert np.array_equal(small, np.full(len(ys), each_small))


@pytest.mark.parametrize("hole_px, each_small", [(8, False), (10, True)])
def test_a_large_canvas_bridges_holes_in_whole_squares(hole_px, each_small):
    """On a canvas of 2 x 2 squares (more than ``MAX_DECISION_PIXELS`` pixels) the reach of 3 px is
    2 squares: sixteen 8 x 8 blobs (64 pixels each) 8 px apart are one piece, 10 px apart sixteen."""
    shape = (200, 200)
    blobs = _blobs(shape, slice(0, 4 * (8 + hole_px)), slice(0, 4 * (8 + hole_px)), 8, hole_px)
    other = np.zeros(shape, bool)
    other[120:, :] = True                                     # a solid other part, for the pixel count
    ys, xs = np.nonzero(blobs | other)
    canvas, _, _ = PixelCanvas.of_pixels(ys, xs)
    assert canvas.block == 2
    where = blobs[canvas.ys, canvas.xs]
    assert np.array_equal(canvas.small_pieces(where, MIN_OBJECT_PIXELS), where & each_small)


def test_bridged_holes_add_no_pixels_to_a_piece():
    """Two 4 x 4 blobs 2 px apart are one piece of 32 pixels, the 8 pixels of the hole between them
    not counted: smaller than 40."""
    blobs = _blobs((4, 10), slice(0, 4), slice(0, 10), 4, 2)
    ys, xs = np.nonzero(blobs)
    canvas, _, _ = PixelCanvas.of_pixels(ys, xs)
    assert canvas.small_pieces(np.ones(len(ys), bool), 40).all()
    assert not canvas.small_pieces(np.ones(len(ys), bool), 32).any()


def test_pixels_of_the_other_part_are_not_holes():
    """Blobs 2 pixels apart across pixels of the other part are not bridged: each is a small piece
    (texture within the other colour, a brick wall's mortar)."""
    shape = (40, 40)
    blobs = _blobs(shape, slice(0, 36), slice(0, 36), 4, 2)
    ys, xs = np.nonzero(np.ones(shape, bool))
    canvas, _, _ = PixelCanvas.of_pixels(ys, xs)
    where = blobs[ys, xs]
    assert np.array_equal(canvas.small_pieces(where, MIN_OBJECT_PIXELS), where)


@pytest.mark.parametrize("first, third", [(GREEN, (150, 100)), ((150, 100), GREEN)])
def test_three_objects_need_two_levels(first, third):
    """A cylinder 1 px in front of a brown wall, a panel 1 px behind it: one of them splits off
    first (the other two colours lie nearer each other), then the other."""
    scene = (Scene((90, 160)).paint(slice(10, 40), slice(50, 110), first, 7.0)
             .paint(slice(40, 90), slice(10, 150), BROWN, 8.0).paint(slice(30, 90), slice(110, 134), third, 9.0))
    split = scene.split()
    assert split.max() == 2 and _same_parts(split, scene.objects)
    assert scene.split(replace(ColourSplitParameters(), max_levels=1)).max() == 1


def test_uncoloured_pixels_follow_the_nearest_coloured_part():
    """Ground-coloured pixels at the foot of a pole standing in front of a box's upper half (raised
    by their disparity, not by their colour) go with the pole, whatever their disparity: within a
    part split off by chroma, phase 1's verdict is not tried again."""
    scene = (Scene().paint(slice(10, 50), slice(20, 100), BROWN, 7.0).paint(slice(0, 80), slice(53, 67), BLUE, 7.6)
             .paint(slice(72, 80), slice(50, 70), (145, 145), 7.0, coloured=False))      # nearer brown than blue
    split = scene.split()
    assert split.max() == 1
    assert np.all(split[scene.objects == 2] == split[5, 60])
    assert np.all(split[scene.objects == 0] != split[5, 60])


def test_an_object_coloured_like_the_ground_is_split_from_a_coloured_one_at_another_depth():
    """A box coloured like the ground stands only by its disparity: beside a wall 1.3 px farther
    it is split off by phase 1's verdict, though the two have one chroma."""
    scene = (Scene().paint(slice(0, 70), slice(10, 50), GREEN, 6.8)
             .paint(slice(30, 80), slice(50, 110), GREEN, 8.1, coloured=False))
    split = scene.split()
    assert split.max() == 1 and _same_parts(split, scene.objects)


def test_a_ground_coloured_speck_apart_goes_to_the_coloured_part():
    """Connected pieces smaller than an object go to the other cluster with phase 1's verdict too
    (one farther than the boundary's reach from the other part, where the planes would decide)."""
    scene = (Scene().paint(slice(0, 70), slice(24, 50), GREEN, 6.8)
             .paint(slice(30, 80), slice(50, 110), GREEN, 8.1, coloured=False)
             .paint(slice(10, 16), slice(2, 8), GREEN, 6.8, coloured=False))      # 16 px left of the wall
    split = scene.split()
    assert split.max() == 1
    assert np.all(split[scene.objects == 2] == split[5, 30]) and split[5, 30] != split[50, 80]


def test_a_coloured_object_of_less_than_two_objects_pixels_is_split_from_a_ground_coloured_one():
    """Phase 1's verdict needs one object's coloured pixels, not the two the chroma clusters need."""
    coloured_rows = 15                                                          # 15 x 12 = 180 px < 2 x 120
    scene = (Scene().paint(slice(10, 10 + coloured_rows), slice(20, 32), GREEN, 6.8)
             .paint(slice(5, 75), slice(32, 92), GREEN, 8.1, coloured=False))
    assert MIN_OBJECT_PIXELS <= np.count_nonzero(scene.coloured) < 2 * MIN_OBJECT_PIXELS
    split = scene.split()
    assert split.max() == 1 and _same_parts(split, scene.objects)


@pytest.mark.parametrize("box_disparity", [7.0, 6.9])
def test_ground_coloured_pixels_at_the_same_depth_are_not_split_off(box_disparity):
    """Within the gap (0.3 px here) the ground-coloured part is the same surface."""
    scene = (Scene().paint(slice(0, 70), slice(10, 50), GREEN, 6.8)
             .paint(slice(30, 80), slice(50, 110), GREEN, box_disparity, coloured=False))
    assert scene.split().max() == 0


def test_a_ground_coloured_halo_behind_an_object_is_not_split_off():
    """The ground the matching spreads around an object lies behind it: a rim."""
    scene = (Scene().paint(slice(10, 70), slice(20, 100), GREY, 7.0, coloured=False)
             .paint(slice(13, 67), slice(23, 97), BLUE, 8.0))
    assert np.count_nonzero(scene.objects == 0) >= MIN_OBJECT_PIXELS
    assert scene.split().max() == 0


def test_a_large_group_is_decided_on_squares_of_pixels():
    scene = _pole_before_box((160, 240), scale=2)
    assert np.count_nonzero(scene.objects >= 0) > MAX_DECISION_PIXELS
    split = scene.split()
    assert split.max() == 1
    for obj in (0, 1):
        labels = np.bincount(split[scene.objects == obj])
        assert labels.max() >= 0.98 * labels.sum()                       # a square across the edge at most


def test_a_rim_around_a_large_object_is_not_split_off_either():
    """Decided on squares of 5 x 5 pixels, the 3 px ring lies in the squares next to the box's."""
    scene = (Scene((410, 410)).paint(slice(2, 408), slice(2, 408), BLUE, 8.0)
             .paint(slice(5, 405), slice(5, 405), BROWN, 9.0))
    assert math.ceil(math.sqrt(np.count_nonzero(scene.objects >= 0) / MAX_DECISION_PIXELS)) == 5
    assert scene.split().max() == 0


@pytest.mark.parametrize("rows, split", [(40, True), (16, False)])
def test_pixel_counts_of_a_large_group_are_its_pixels_not_its_squares(rows, split):
    """A pole above a large box, matched at one pixel in four: 280 pixels are an object's size,
    112 are not, though their squares of 2 x 2 pixels would stand for 448."""
    scene = _pole_before_box((160, 240), scale=2)
    pole = scene.objects == 1
    even = (np.arange(160)[:, None] % 2 == 0) & (np.arange(240)[None, :] % 2 == 0)
    dropped = pole & ~(even & (np.arange(160)[:, None] < rows))
    scene.objects[dropped], scene.d[dropped] = -1, np.nan
    assert np.count_nonzero(scene.objects == 1) == rows // 2 * 14
    assert np.count_nonzero(scene.objects >= 0) > MAX_DECISION_PIXELS
    assert scene.split().max() == (1 if split else 0)


def test_only_groups_of_twice_an_object_are_split():
    scene = Scene().paint(slice(0, 10), slice(0, 11), BROWN, 7.0).paint(slice(0, 10), slice(11, 22), BLUE, 8.0)
    assert np.count_nonzero(scene.objects >= 0) < 2 * MIN_OBJECT_PIXELS
    assert scene.split().max() == 0


def test_other_groups_keep_their_labels_and_parts_get_the_next_ones():
    scene = _pole_before_box((80, 240))
    scene.paint(slice(30, 80), slice(140, 220), BROWN, 7.0).paint(slice(0, 80), slice(173, 187), BLUE, 7.6)
    groups = np.where(scene.objects >= 0, np.where(np.arange(240) < 120, 1, 2)[None, :], -1)
    groups[:5, :5] = 0
    split = split_groups_by_colour(groups, scene.d, ColourCue(scene.chroma, scene.coloured),
                                   min_object_pixels=MIN_OBJECT_PIXELS)
    assert np.all(split[:5, :5] == 0)
    assert set(np.unique(split[:, :120][groups[:, :120] > 0]).tolist()) == {1, 3}
    assert set(np.unique(split[:, 120:][groups[:, 120:] > 0]).tolist()) == {2, 4}


def test_the_grouping_splits_by_colour_only_with_a_colour_cue():
    scene = _pole_before_box(gap_px=0.4)          # closer than the depth-layer split tells apart
    cue = ColourCue(scene.chroma, scene.coloured)
    mask = scene.objects >= 0
    assert group_obstacle_pixels(scene.d, mask).max() == 1
    assert group_obstacle_pixels(scene.d, mask, colour=cue).max() == 2
    off = replace(GroupingParameters(), colour_split=None)
    assert group_obstacle_pixels(scene.d, mask, off, colour=cue).max() == 1


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2 ** 32 - 1))
def test_a_split_only_divides_groups(seed):
    rng = np.random.default_rng(seed)
    shape = (48, 64)
    groups = rng.integers(-1, 3, (6, 8)).repeat(8, axis=0).repeat(8, axis=1)
    d = rng.choice([6.0, 6.8, 8.0], (6, 8)).repeat(8, axis=0).repeat(8, axis=1).astype(np.float32)
    chroma = rng.choice([100, 128, 160], (6, 8, 2)).repeat(8, axis=0).repeat(8, axis=1).astype(np.uint8)
    cue = ColourCue(chroma, rng.random(shape) < 0.9)
    split = split_groups_by_colour(groups, d, cue, min_object_pixels=64)
    np.testing.assert_array_equal(split < 0, groups < 0)
    for label in np.unique(split[split >= 0]):
        assert len(np.unique(groups[split == label])) == 1
    new = np.unique(split[split > groups.max()])
    np.testing.assert_array_equal(new, np.arange(groups.max() + 1, groups.max() + 1 + new.size))


def test_colour_cue_takes_the_chroma_of_the_blurred_image():
    left = np.zeros((20, 30, 3), np.uint8)
    left[:, :15] = (200, 40, 40)
    left[:, 15:] = (128, 128, 128)
    cue = colour_cue(left, np.ones((20, 30), bool), ColourSplitParameters(blur_px=1))
    assert cue.chroma.dtype == np.uint8 and cue.chroma.shape == (20, 30, 2)
    assert cue.chroma[0, 0, 0] > 160 and np.all(np.abs(cue.chroma[:, 15:].astype(int) - 128) <= 1)
    blurred = colour_cue(left, np.ones((20, 30), bool), ColourSplitParameters(blur_px=5))
    assert 128 < blurred.chroma[10, 15, 0] < cue.chroma[10, 0, 0]


def test_colour_cue_refuses_images_it_cannot_read():
    with pytest.raises(InvalidInputError, match="uint8 \\(H, W, 3\\)"):
        colour_cue(np.zeros((4, 4, 3), np.float32), np.ones((4, 4), bool), ColourSplitParameters())
    with pytest.raises(InvalidInputError, match="coloured"):
        colour_cue(np.zeros((4, 4, 3), np.uint8), np.ones((4, 5), bool), ColourSplitParameters())


def _grey_box_before_grey_wall(box_disparity):
    """A grey wall (disparity 7.0, 6 m) seen above a grey box standing in front of it."""
    return (Scene().paint(slice(0, 40), slice(20, 100), GREY, 7.0)
            .paint(slice(40, 80), slice(20, 100), GREY, box_disparity))


def test_two_depths_of_one_colour_are_split_with_a_calibration_where_they_stand_apart():
    scene = _grey_box_before_grey_wall(7.6)                 # the box 0.47 m in front of the wall
    assert scene.split().max() == 0                         # no second colour: nothing to split by
    assert _same_parts(scene.split(calibration=RIG), scene.objects)
    assert scene.split(ColourSplitParameters(depth_gap_m=0.0), calibration=RIG).max() == 0     # switched off


def test_two_depths_whose_footprints_touch_are_not_split():
    # 0.35 px apart at 6 m passes every test of two surfaces at two depths, but the box stands
    # 0.29 m in front of the wall: within depth_gap_m, as one object's faces do
    scene = _grey_box_before_grey_wall(7.35)
    assert scene.split(calibration=RIG).max() == 0
    assert _same_parts(scene.split(ColourSplitParameters(depth_gap_m=0.25), calibration=RIG), scene.objects)
    # footprints of fewer points than depth_touch_points say nothing: nothing is split
    assert scene.split(ColourSplitParameters(depth_gap_m=0.25, depth_touch_points=10 ** 6), calibration=RIG).max() == 0


def test_footprints_touch_when_each_has_depth_touch_points_points_within_the_gap():
    # a box 0.29 m before a wall, half under it and half beside it: the points of each footprint
    # under the other's lie within 0.3 m of it, the others do not
    scene = (Scene().paint(slice(0, 40), slice(10, 80), GREY, 7.0)
             .paint(slice(40, 80), slice(40, 110), GREY, 7.35))
    prints = [footprint(np.nonzero(scene.objects == k)[1], scene.d[scene.objects == k], RIG) for k in (0, 1)]
    counts = close_points(prints[0], prints[1], ColourSplitParameters().depth_gap_m)
    assert counts[0] != counts[1] and max(counts) < min(map(len, prints))
    assert scene.split(ColourSplitParameters(depth_touch_points=min(counts)), calibration=RIG).max() == 0
    assert _same_parts(scene.split(ColourSplitParameters(depth_touch_points=min(counts) + 1), calibration=RIG),
                       scene.objects)


def test_a_part_without_a_footprint_does_not_stand_apart():
    # two rows of a grey kerb before a grey wall: no column holds 3 of its pixels
    scene = Scene().paint(slice(0, 60), slice(10, 110), GREY, 7.0).paint(slice(60, 62), slice(10, 110), GREY, 7.6)
    assert scene.split(calibration=RIG).max() == 0


@pytest.mark.parametrize("rows", [60, 400])
def test_a_large_group_stands_apart_as_a_small_one_does(rows):
    # decided on squares of pixels above MAX_DECISION_PIXELS, its footprints still come from every pixel
    assert 60 * 100 < MAX_DECISION_PIXELS < 400 * 100
    for near_d, split in ((8.35, False), (8.6, True)):    # 0.22 m and 0.37 m before the other at 5.25 m
        scene = (Scene((rows, 140)).paint(slice(0, rows), slice(20, 70), GREY, 8.0)
                 .paint(slice(0, rows), slice(70, 120), GREY, near_d))
        assert scene.split(calibration=RIG).max() == int(split)       # squares of 3 x 3 straddle the boundary


def test_a_grey_rim_behind_a_grey_object_is_not_split_off_though_it_stands_apart():
    # the halo of background the matching spreads around an object: its footprint stands apart,
    # but the depth clusters face the same tests as colour clusters
    scene = Scene().paint(slice(10, 80), slice(10, 110), GREY, 7.0).paint(slice(14, 80), slice(14, 106), GREY, 7.6)
    prints = [footprint(np.nonzero(scene.objects == k)[1], scene.d[scene.objects == k], RIG) for k in (0, 1)]
    assert min(map(len, prints)) >= 2 and close_points(*prints, 0.3) == (0, 0)
    assert scene.split(calibration=RIG).max() == 0


def test_one_slanted_surface_of_one_colour_is_not_split_into_depths():
    # its two depth clusters touch on the ground, and the step test finds their planes meeting
    ramp = Scene().paint(slice(0, 80), slice(10, 110), GREY, lambda xs: 6.0 + 0.02 * xs)
    assert ramp.split(calibration=RIG).max() == 0


def test_inputs_of_other_sizes_or_types_are_refused():
    scene = _pole_before_box()
    groups, cue = np.where(scene.objects >= 0, 0, -1), ColourCue(scene.chroma, scene.coloured)
    with pytest.raises(InvalidInputError, match="colour cue"):
        split_groups_by_colour(groups, scene.d, ColourCue(scene.chroma[:-1], scene.coloured[:-1]),
                               min_object_pixels=120)
    with pytest.raises(InvalidInputError, match="disparity"):
        split_groups_by_colour(groups, scene.d[:, :-1], cue, min_object_pixels=120)
    with pytest.raises(InvalidInputError, match="min_object_pixels"):
        split_groups_by_colour(groups, scene.d, cue, min_object_pixels=0)
    with pytest.raises(InvalidInputError, match="calibration must be a StereoCalibration"):
        split_groups_by_colour(groups, scene.d, cue, min_object_pixels=120, calibration={"focal_px": 350.0})
    with pytest.raises(InvalidInputError, match="coloured must be bool"):
        ColourCue(scene.chroma, scene.coloured.astype(np.uint8))
    with pytest.raises(InvalidInputError, match="chroma must be uint8"):
        ColourCue(scene.chroma.astype(np.float32), scene.coloured)


def test_a_group_with_a_pixel_without_disparity_is_left_whole():
    scene = _pole_before_box()
    scene.d[40, 30] = np.nan
    assert scene.split().max() == 0


@pytest.mark.parametrize("field, value", [("blur_px", 0), ("blur_px", 2.5), ("min_chroma_distance", -1.0),
                                          ("min_gap_px", float("nan")), ("min_gap_rel", 2.0),
                                          ("min_plane_fraction", 1.5), ("max_levels", 0), ("depth_gap_m", -0.1),
                                          ("depth_touch_points", 0)])
def test_parameters_out_of_range_are_refused(field, value):
    with pytest.raises(InvalidInputError, match=field):
        ColourSplitParameters(**{field: value})


def test_grouping_parameters_refuse_a_colour_split_of_another_type():
    with pytest.raises(InvalidInputError, match="colour_split"):
        GroupingParameters(colour_split={"blur_px": 5})


def _two_means_reference(chroma, coloured, max_sample, max_rounds):
    points = chroma[coloured].astype(float)
    points = points[::-(-len(points) // max_sample)]
    centred = points - points.mean(axis=0)
    w, v = np.linalg.eigh(centred.T @ centred)
    second = centred @ v[:, np.argmax(w)] > 0
    for _ in range(max_rounds):
        centres = np.stack([points[~second].mean(axis=0), points[second].mean(axis=0)])
        nearer = ((points - centres[1]) ** 2).sum(axis=1) < ((points - centres[0]) ** 2).sum(axis=1)
        if np.array_equal(nearer, second):
            break
        second = nearer
    clusters = ((chroma - centres[1]) ** 2).sum(axis=1) < ((chroma - centres[0]) ** 2).sum(axis=1)
    return centres, clusters


@pytest.mark.parametrize("seed", range(4))
def test_two_colours_kernel_agrees_with_numpy(seed):
    rng = np.random.default_rng(seed)
    n = 5000
    chroma = np.where(rng.random((n, 1)) < 0.3, rng.normal(150, 6, (n, 2)), rng.normal(110, 6, (n, 2)))
    chroma = np.clip(chroma, 0, 255).astype(np.uint8)
    coloured = rng.random(n) < 0.8
    centres, clusters = two_colours_kernel(chroma, coloured, 2000, 20)
    expected_centres, expected_clusters = _two_means_reference(chroma, coloured, 2000, 20)
    order = np.argsort(centres[:, 0])                                      # the axis may point either way
    np.testing.assert_allclose(centres[order], expected_centres[np.argsort(expected_centres[:, 0])], atol=1e-9)
    flip = order[0] != np.argsort(expected_centres[:, 0])[0]
    np.testing.assert_array_equal(clusters.astype(bool) ^ flip, expected_clusters)


@pytest.mark.parametrize("any_coloured", [True, False])
def test_two_colours_kernel_finds_no_centres_without_spread_or_colour(any_coloured):
    chroma = np.full((50, 2), 128, np.uint8) if any_coloured else np.arange(100, dtype=np.uint8).reshape(50, 2)
    centres, clusters = two_colours_kernel(chroma, np.full(50, any_coloured), 2000, 20)
    assert np.isnan(centres).all() and not clusters.any()


def test_group_runs_kernel_agrees_with_numpy():
    rng = np.random.default_rng(5)
    groups = rng.integers(-1, 7, 3000)
    coloured = rng.random(3000) < 0.5
    counts, coloured_counts, starts, pixels = group_runs_kernel(groups, coloured, 7)
    for g in range(7):
        members = np.flatnonzero(groups == g)
        assert counts[g] == members.size and coloured_counts[g] == np.count_nonzero(coloured[members])
        np.testing.assert_array_equal(pixels[starts[g]:starts[g + 1]], members)


def test_one_per_block_kernel_takes_the_first_pixel_of_each_square():
    rng = np.random.default_rng(6)
    rows, columns = rng.integers(0, 5, 400), rng.integers(0, 7, 400)
    chosen, square_of = one_per_block_kernel(rows, columns)
    keys = rows * 7 + columns
    _, first = np.unique(keys, return_index=True)
    np.testing.assert_array_equal(np.sort(chosen), np.sort(first))
    np.testing.assert_array_equal(keys[chosen[square_of]], keys)


def test_an_empty_cluster_is_not_apart_in_depth():
    """A 2-means stopped by its round limit may leave a cluster without coloured pixels."""
    from stereo_obstacles.colour_split import _median_gap

    d = np.array([7.0, 8.0, 9.0])
    params = ColourSplitParameters()
    assert _median_gap(d, np.array([True, True, True]), np.zeros(3, bool), params) == (0.0, params.min_gap_px)
    assert _median_gap(d, np.array([True, False, False]), np.array([False, False, True]), params)[0] == 2.0


def test_detect_splits_a_cylinder_from_the_pole_in_front_of_it_by_their_footprints():
    # scene 328: a cylinder at 6.15 m behind a pole at 5.02 m came out of the grouping as one
    # obstacle with the pole, at the pole's distance (-17.7 % for the cylinder, which it covers
    # most); the colour clusters fail the split's tests, and the depth clusters stand apart on the
    # ground. (Since session 30 the depth-layer split splits them first, and so do the colour
    # clusters at the default plane share, 0.65 then and 0.6 since session 45; here both are as
    # they were before. Since session 31's pieces bridged across unmatched holes it reads -2.6 %
    # here, +0.7 % before; with the defaults +0.7 % until session 44, +0.9 % since session 45.)
    from stereo_obstacles.pipeline import DetectionConfig

    pair = evaluation_pair(328)
    cylinder = true_obstacle(pair, "cylinder", 6.15)
    default = DetectionConfig()
    config = replace(default, grouping=replace(
        default.grouping, split_tolerance_px=0.75, split_min_step_px=0.0,
        colour_split=replace(default.grouping.colour_split, min_plane_fraction=0.7)))
    whole = replace(config, grouping=replace(config.grouping,
                                             colour_split=replace(config.grouping.colour_split, depth_gap_m=0.0)))
    assert comparison(pair, cylinder, whole)[0].relative_error < -0.15
    assert abs(comparison(pair, cylinder, config)[0].relative_error) < 0.05


@pytest.mark.parametrize("seed, noise_sigma, distance_m", [(492, 0.0, 3.75), (494, 0.0, 8.41), (2, 2.0, 8.24)])
def test_detect_keeps_a_wall_whole_that_the_depth_clusters_cut_across(seed, noise_sigma, distance_m):
    # the 2-means cuts each of these walls across its receding face, and the edge columns left out
    # on either side of the cut can open a gap between the parts' footprints (split, the walls read
    # +15.1 %, +6.4 % and +10.6 % in the variants of docs/pipeline.md, session 28): 494's parts
    # stand apart before the colour split's tests and seed 2's after them, and the other comparison
    # keeps each whole; 492's touch in both
    pair = evaluation_pair(seed, noise_sigma)
    assert abs(comparison(pair, true_obstacle(pair, "wall", distance_m))[0].relative_error) < 0.05
