"""Filling textureless faces from their outlines: a box on the ground is filled, the sky between
two poles is not, and neither is a face whose outlines disagree or that does not meet the ground."""

from __future__ import annotations

import numpy as np
import pytest

from _obstacle_scene import CAMERA_HEIGHT_M, GROUND, RIG
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.labels import Label
from stereo_obstacles.face_joining import obstacles_sharing_a_face
from stereo_obstacles.textureless_fill import (TexturelessFillParameters, bracketed_runs, fill_textureless,
                                               textureless_candidates, widen_obstacles)

H, W = RIG.height_px, RIG.width_px
OUTLINE_PX = 3
BOX_ROWS = slice(138, 225)                 # a 1 m box 4 m ahead of a camera 1.2 m high: rows 138-224


def _world(box_m: float = 4.0, right_outline_m: float | None = None, floating: bool = False, right_id: int = 1,
           hanging_rows: int = 12, hanging_columns: slice = slice(120, 200), outline_rows: float = 1.0,
           shadow_below: bool = False):
    """Ground below the horizon, sky above; a dark box of one flat colour ``box_m`` ahead at
    columns 120-199, matched only along its left and right outlines (obstacle 1, the right one
    at ``right_outline_m`` and numbered ``right_id``); two poles 5 m ahead at columns 20-29 and 60-69 (obstacles
    2 and 3) rising into the sky. ``floating``: the box stands on nothing: an unmatched obstacle
    of its colour hangs ``hanging_rows`` below it over ``hanging_columns``. ``outline_rows``: the
    fraction of the box's rows (from its bottom) whose right outline is matched. ``shadow_below``:
    the ground under the box is in its shadow."""
    rows = np.arange(H)[:, None]
    labels = np.where(np.broadcast_to(rows, (H, W)) > RIG.cy_px, Label.GROUND.value,
                      Label.OBSTACLE.value).astype(np.uint8)                       # the sky is an obstacle by colour
    left = np.zeros((H, W, 3), np.uint8)
    left[:] = (150, 190, 230)
    checks = ((np.arange(W)[None, :] // 6 + rows // 6) % 2 * 40 + 90).astype(np.uint8)
    left[rows[:, 0] > RIG.cy_px] = np.stack([checks] * 3, axis=-1)[rows[:, 0] > RIG.cy_px]
    disparity = np.where(rows > RIG.cy_px, GROUND.disparity_at(np.arange(W)[None, :], rows), np.nan).astype(np.float32)
    ids = np.zeros((H, W), np.int32)

    def stand(x0, x1, z_m, height_m, rgb, obstacle, matched_columns):
        bottom = int(round(RIG.cy_px + RIG.focal_px * CAMERA_HEIGHT_M / z_m))
        top = int(round(bottom - RIG.focal_px * height_m / z_m))
        labels[top:bottom, x0:x1] = Label.OBSTACLE.value
        left[top:bottom, x0:x1] = rgb
        disparity[top:bottom, x0:x1] = np.nan
        for columns, z, number in matched_columns:
            disparity[top:bottom, columns] = RIG.focal_baseline_px_m / z
            ids[top:bottom, columns] = number
        return top, bottom

    right_z = box_m if right_outline_m is None else right_outline_m
    top, bottom = stand(120, 200, box_m, 1.0, (45, 45, 50), 1,
                        [(slice(120, 120 + OUTLINE_PX), box_m, 1), (slice(200 - OUTLINE_PX, 200), right_z, right_id)])
    unmatched = slice(top, bottom - int(round(outline_rows * (bottom - top))))
    disparity[unmatched, 200 - OUTLINE_PX:200], ids[unmatched, 200 - OUTLINE_PX:200] = np.nan, 0
    if shadow_below:
        labels[bottom:bottom + 30, 110:210] = Label.SHADOW.value
    if floating:
        below = slice(bottom, bottom + hanging_rows)
        labels[below, hanging_columns] = Label.OBSTACLE.value
        left[below, hanging_columns] = (45, 45, 50)
        disparity[below, hanging_columns] = np.nan
    for x0, obstacle in ((20, 2), (60, 3)):
        pole_top, _ = stand(x0, x0 + 10, 5.0, 3.0, (200, 40, 40), obstacle, [(slice(x0, x0 + 10), 5.0, obstacle)])
        labels[:pole_top, x0:x0 + 10] = Label.OBSTACLE.value          # the pole's top leaves the image
        left[:pole_top, x0:x0 + 10] = (200, 40, 40)
        disparity[:pole_top, x0:x0 + 10] = RIG.focal_baseline_px_m / 5.0
        ids[:pole_top, x0:x0 + 10] = obstacle
    return ids, disparity, labels, left


def _fill(world, params=TexturelessFillParameters()):
    ids, disparity, labels, left = world
    return fill_textureless(textureless_candidates(labels, left, params), ids, disparity, labels, GROUND, params)


def test_a_flat_box_on_the_ground_is_filled_at_its_outlines_depth():
    ids, disparity, labels, left = world = _world()
    filled_ids, filled = _fill(world)
    inside = np.zeros((H, W), bool)
    inside[BOX_ROWS, 120 + OUTLINE_PX:200 - OUTLINE_PX] = True
    box = filled_ids[inside] == 1
    assert box.mean() > 0.9                                             # all but the rim the edges keep empty
    np.testing.assert_allclose(filled[inside][box], RIG.focal_baseline_px_m / 4.0, rtol=1e-5)
    assert np.array_equal(filled_ids[ids > 0], ids[ids > 0]) and np.array_equal(filled[ids > 0], disparity[ids > 0])


def test_the_sky_between_two_poles_is_left_empty():
    filled_ids, filled = _fill(_world())
    between = (slice(0, int(RIG.cy_px)), slice(30, 60))
    assert not filled_ids[between].any() and np.isnan(filled[between]).all()


def test_a_fill_takes_the_nearer_outline_and_interpolates_between_them():
    ids, disparity, labels, left = world = _world(box_m=4.0, right_outline_m=3.8, right_id=4)   # within the 10 %
    filled_ids, filled = _fill(world)
    row = 180
    values = filled[row, 120 + OUTLINE_PX:200 - OUTLINE_PX]
    assert np.all(np.diff(values[np.isfinite(values)]) > 0)             # rising towards the nearer right outline
    assert set(np.unique(filled_ids[row, 125:195])) == {4}                 # the id of the nearer end


LOOSE_CONTACT = TexturelessFillParameters(contact_tolerance_fraction=0.5)


@pytest.mark.parametrize("world, params, why", [
    (lambda: _world(box_m=4.0, right_outline_m=3.4), LOOSE_CONTACT, "outlines 15 % apart: two surfaces"),
    (lambda: _world(floating=True), TexturelessFillParameters(), "it meets the ground nearer than its outlines"),
    (lambda: _world(floating=True, hanging_rows=60, hanging_columns=slice(120, 190)), TexturelessFillParameters(),
     "a few of its columns meet the ground (at its depth), the others none within 40 rows"),
])
def test_a_face_is_left_empty_unless_one_surface_continues_and_stands_on_the_ground(world, params, why):
    ids, disparity, labels, left = w = world()
    filled_ids, filled = _fill(w, params)
    assert np.array_equal(filled_ids, ids) and np.array_equal(np.isnan(filled), np.isnan(disparity)), why


def _receding_face(near_m: float, far_m: float, step: bool = False):
    """:func:`_world` with its box replaced by a dark face 1 m tall standing on the ground in columns
    120-199, matched only along its outlines (obstacle 1 left, obstacle 4 right): a plane receding
    from ``near_m`` at its left outline to ``far_m`` at its right (its disparity linear across it), or
    with ``step`` two faces of its colour side by side, the left half at ``near_m`` and the right
    half at ``far_m``. Returns the world, the face's true disparity per column (``(80,)``) and
    ``bool (H, W)``: its pixels between the outlines."""
    ids, disparity, labels, left = _world()
    face, clear = slice(120, 200), slice(216, 296)          # clear ground and sky, the checks in phase
    for layer in (ids, disparity, labels, left):
        layer[:, face] = layer[:, clear]
    near_d, far_d = (RIG.focal_baseline_px_m / z for z in (near_m, far_m))
    t = np.arange(80) / 79
    between = np.zeros((H, W), bool)
    true_d = np.where(t < 0.5, near_d, far_d) if step else near_d + (far_d - near_d) * t
    for k, d in enumerate(true_d):
        x = 120 + k
        bottom = int(round(RIG.cy_px + d * CAMERA_HEIGHT_M / RIG.baseline_m))       # f h / Z
        top = int(round(bottom - d / RIG.baseline_m))                               # 1 m tall
        labels[top:bottom, x], left[top:bottom, x], disparity[top:bottom, x] = Label.OBSTACLE.value, (45, 45, 50), np.nan
        if k < OUTLINE_PX or k >= 80 - OUTLINE_PX:
            disparity[top:bottom, x], ids[top:bottom, x] = d, 1 if k < OUTLINE_PX else 4
        else:
            between[top:bottom, x] = True
    return (ids, disparity, labels, left), true_d, between


def test_a_face_receding_in_depth_is_filled_along_its_slant():
    # outlines at 4.0 and 4.6 m, 13 % apart in disparity: no longer one depth, but each stands
    # on the ground where the face meets it, along a straight line
    world, true_d, between = _receding_face(4.0, 4.6)
    ids = world[0]
    bracketed_rows = (ids[:, 120] == 1) & (ids[:, 199] == 4)                  # the face's top slants down to the right
    filled_ids, filled = _fill(world)
    assert np.isfinite(filled[between & bracketed_rows[:, None]]).mean() > 0.9    # but the rim the edges keep empty
    columns = np.nonzero(between)[1]
    error = filled[between] - true_d[columns - 120]
    assert np.nanmax(np.abs(error)) < 0.1                                     # 1.37 px from end to end
    assert set(np.unique(filled_ids[between & np.isfinite(filled)])) == {1}   # the nearer outline's id


def test_two_faces_at_two_depths_meeting_the_ground_with_a_step_are_left_empty():
    world, _, _ = _receding_face(4.0, 4.6, step=True)
    filled_ids, filled = _fill(world)
    assert np.array_equal(filled_ids, world[0]) and np.array_equal(np.isnan(filled), np.isnan(world[1]))


def _runs(world):
    ids, disparity, labels, left = world
    return bracketed_runs(textureless_candidates(labels, left), ids, disparity, labels, GROUND)


def test_a_receding_face_meets_the_ground_at_its_outlines_depths_and_its_outlines_are_joined():
    world, true_d, _ = _receding_face(4.0, 4.6)
    runs = _runs(world)
    # the contacts: the mean of the ground met in the run's first and last 3 columns (0.1 px a row)
    np.testing.assert_allclose(runs.contact_left, true_d[OUTLINE_PX + 1], atol=0.12)
    np.testing.assert_allclose(runs.contact_right, true_d[80 - OUTLINE_PX - 2], atol=0.12)
    assert obstacles_sharing_a_face(runs, world[0], world[1], RIG) == [(1, 4)]


@pytest.mark.parametrize("near_m, far_m", [(4.0, 4.35), (5.0, 5.35), (6.0, 6.5), (8.0, 8.35), (8.0, 8.6)])
def test_two_objects_of_one_colour_a_little_apart_in_depth_are_not_joined_as_one_face(near_m, far_m):
    # each stands on the ground at its own depth, but the ground steps between them; from 5 m on
    # the step (0.55 px at 5 m, 0.22 px at 8 m) lies within twice the line's 0.3 px (two reviews
    # of session 43 joined them)
    world, _, _ = _receding_face(near_m, far_m, step=True)
    runs = _runs(world)
    assert runs is None or obstacles_sharing_a_face(runs, world[0], world[1], RIG) == []


@pytest.mark.parametrize("near_m, far_m", [(5.0, 5.35), (6.0, 6.5), (8.0, 8.6)])
def test_a_face_receding_a_little_far_away_is_still_one_face(near_m, far_m):
    world, _, _ = _receding_face(near_m, far_m)
    assert obstacles_sharing_a_face(_runs(world), world[0], world[1], RIG) == [(1, 4)]


def test_rows_whose_ends_agree_are_held_to_the_contact_tolerance_as_before():
    # ends 8 % apart (within the ends' 10 %), the nearer 0.33 m in front of the ground it meets:
    # with the contact tolerance at 0.5 px the box is not filled, as before the slanted rows came
    tight = TexturelessFillParameters(contact_tolerance_px=0.5, end_tolerance_px=0.5)
    world = _world(box_m=4.0, right_outline_m=3.67)
    assert np.array_equal(_fill(world, tight)[0], world[0])


def test_end_contacts_need_the_ground_met_along_most_of_the_run_and_on_one_line():
    from stereo_obstacles.textureless_fill import _end_contacts, _GroundMet

    def contacts_of(ground_d):                          # region 1 meets the ground below columns 0..19
        xs = np.flatnonzero(np.isfinite(ground_d))
        rows = np.stack([np.ones_like(xs), xs, np.zeros_like(xs)], axis=1)
        met = _GroundMet.of(rows, ground_d[xs], 1, 20)
        one = np.array([1])
        left, right, stepped = _end_contacts(met, one, np.array([0]), np.array([19]), np.array([True]),
                                             TexturelessFillParameters())
        return left[0], right[0], bool(stepped[0])

    line = np.linspace(10.0, 12.0, 20)
    np.testing.assert_allclose(contacts_of(line), (line[1], line[18], False))      # the 3-column means
    steep = np.linspace(10.0, 19.5, 20)                 # 0.5 px a column: the line through the windows' centres
    assert np.isfinite(contacts_of(steep)[:2]).all()
    for level in (10.1, 13.7, 27.3):                    # a face at one depth: a step and a line fit it alike
        assert np.isfinite(contacts_of(np.full(20, level))[:2]).all() and not contacts_of(np.full(20, level))[2]
    only_ends = np.where((np.arange(20) < 3) | (np.arange(20) > 16), line, np.nan)
    assert np.isnan(contacts_of(only_ends)[:2]).all()                                # 6 of 20 columns met
    left, right, stepped = contacts_of(np.where(np.arange(20) < 10, 10.0, 12.0))
    assert np.isnan([left, right]).all() and not stepped     # 1 px off the line: no contacts, so no step asked
    left, right, stepped = contacts_of(np.where(np.arange(20) < 10, 10.0, 10.4))
    assert np.isfinite([left, right]).all() and stepped                              # within 0.3 px, but a step


def test_a_textured_face_is_no_candidate():
    labels = np.full((60, 80), Label.OBSTACLE.value, np.uint8)
    left = np.full((60, 80, 3), 60, np.uint8)
    assert textureless_candidates(labels, left).max() == 1                          # one plain region
    left[:, 40:] = ((np.arange(40)[None, :] // 6 + np.arange(60)[:, None] // 6) % 2 * 60 + 60)[..., None]
    candidates = textureless_candidates(labels, left)
    assert candidates.max() == 1 and not candidates[:, 42:].any()                   # the checks fall into pieces


def test_a_box_whose_outlines_bracket_under_half_its_rows_is_left_empty():
    world = _world(outline_rows=0.4)
    assert np.array_equal(_fill(world)[0], world[0])
    assert (_fill(_world(outline_rows=0.6))[0] == 1).sum() > 2 * (world[0] == 1).sum()


def test_a_box_standing_in_its_own_shadow_is_filled():
    ids, disparity, labels, left = world = _world(shadow_below=True)
    assert (_fill(world)[0][BOX_ROWS, 125:195] == 1).mean() > 0.9


def test_pixels_of_an_obstacle_without_a_disparity_keep_both():
    ids, disparity, labels, left = _world()
    ids[180:190, 150:160] = 7                                              # e.g. continued into the blind strip
    filled_ids, filled = _fill((ids, disparity, labels, left))
    assert np.all(filled_ids[180:190, 150:160] == 7) and np.isnan(filled[180:190, 150:160]).all()
    assert (filled_ids[BOX_ROWS, 125:195] == 1).mean() > 0.8


def test_a_far_face_seen_between_two_nearer_boxes_is_left_empty():
    """A dark wall 8 m ahead, seen between the dark edges of two boxes 5 m ahead, joined to the
    box 4 m ahead by a dark strip (one region, which as a whole stands at the box's depth): the
    runs between the two edges meet the ground at 8 m in their own columns, not at 5 m."""
    ids, disparity, labels, left = _world()
    dark = (45, 45, 50)
    wall_bottom = int(round(RIG.cy_px + RIG.focal_px * CAMERA_HEIGHT_M / 8.0))
    wall = (slice(wall_bottom - 60, wall_bottom), slice(234, 264))
    bridge = (slice(140, 160), slice(200, 234))
    for area in (wall, bridge):
        labels[area], left[area], disparity[area], ids[area] = Label.OBSTACLE.value, dark, np.nan, 0
    for x0, number in ((230, 8), (264, 9)):                                # the boxes' edges, 5 m ahead
        edge = (slice(wall_bottom - 60, int(round(RIG.cy_px + RIG.focal_px * CAMERA_HEIGHT_M / 5.0))),
                slice(x0, x0 + 4))
        labels[edge], left[edge], ids[edge] = Label.OBSTACLE.value, dark, number
        disparity[edge] = RIG.focal_baseline_px_m / 5.0
    filled_ids, filled = _fill((ids, disparity, labels, left))
    assert (filled_ids[BOX_ROWS, 125:195] == 1).mean() > 0.9                 # the box is filled
    assert not filled_ids[wall].any() and np.isnan(filled[wall]).all()


def test_regions_smaller_than_the_least_area_are_left_empty():
    world = _world()
    filled_ids, _ = _fill(world, TexturelessFillParameters(min_area_px=100_000))
    assert np.array_equal(filled_ids, world[0])


def test_bad_input_is_refused():
    ids, disparity, labels, left = _world()
    with pytest.raises(InvalidInputError, match="must have one shape"):
        fill_textureless(textureless_candidates(labels, left), ids[:, :10], disparity, labels, GROUND)
    with pytest.raises(InvalidInputError, match="one height and width"):
        textureless_candidates(labels[:10], left)
    with pytest.raises(InvalidInputError, match="edge_thresholds"):
        TexturelessFillParameters(edge_thresholds=(60.0, 20.0))
    with pytest.raises(InvalidInputError, match="reach_px"):
        TexturelessFillParameters(reach_px=0)
    for bad in ((1.0, 2.0, 3.0), "ab", (20.0, float("nan"))):
        with pytest.raises(InvalidInputError, match="edge_thresholds"):
            TexturelessFillParameters(edge_thresholds=bad)
    for image in (left[..., 0], left.astype(np.float32), left[:0]):
        with pytest.raises(InvalidInputError, match="uint8 RGB"):
            textureless_candidates(labels[:image.shape[0]], image)
    with pytest.raises(InvalidInputError, match="fit in 32 bits"):
        fill_textureless(textureless_candidates(labels, left), ids.astype(np.int64) + 2 ** 32, disparity, labels,
                         GROUND)


def test_an_obstacle_is_widened_to_its_filled_face_and_the_corridor_follows():
    from stereo_obstacles.obstacles import ObstacleParameters, measure_obstacles

    ids, disparity, labels, left = _world(right_id=4)                  # the outlines two obstacles
    measured = measure_obstacles(ids, disparity, RIG, GROUND, ObstacleParameters(corridor_width_m=0.2))
    box = min(measured.obstacles, key=lambda o: o.lateral_extent_m[0] if o.distance_m < 4.5 else 99)
    assert box.width_m < 0.1 and measured.corridor.nearest_obstacle_id is None       # thin outlines, a free middle
    filled_ids, filled = _fill((measured.id_map, disparity, labels, left))
    wide = widen_obstacles(measured, filled_ids, filled, RIG, 0.2)
    widened = next(o for o in wide.obstacles if o.id == box.id)
    true_x = [(x - RIG.cx_px) * 4.0 / RIG.focal_px for x in (120, 199)]               # the box's columns, 4 m ahead
    assert widened.lateral_extent_m[0] <= true_x[0] + 0.05 and widened.lateral_extent_m[1] >= true_x[1] - 0.05
    assert widened.width_m == pytest.approx(widened.lateral_extent_m[1] - widened.lateral_extent_m[0])
    assert widened.box_px[0] <= 123 and widened.box_px[2] >= 190                     # to the other outline's rim
    assert (widened.distance_m, widened.pixel_count, widened.centre_m) == (box.distance_m, box.pixel_count, box.centre_m)
    assert wide.corridor.nearest_obstacle_id == box.id and wide.corridor.free_distance_m == box.distance_m
    assert widen_obstacles(measured, measured.id_map, disparity, RIG, 0.2) == measured        # nothing filled
    other = next(o for o in measured.obstacles if o.distance_m < 4.5 and o.id != box.id)        # the right outline
    sliver = filled_ids.copy()
    sliver[np.flatnonzero((filled_ids[:, 180] == box.id) & (measured.id_map[:, 180] == 0))[:40], 180] = other.id
    assert (sliver == other.id).sum() - (measured.id_map == other.id).sum() == 40               # 40 of thousands
    pieces = {o.id: o for o in widen_obstacles(measured, sliver, filled, RIG, 0.2).obstacles}
    assert pieces[other.id] == other and pieces[box.id].width_m == widened.width_m             # widened once


def test_widening_takes_only_pixels_of_a_depth_and_refuses_bad_maps():
    from dataclasses import replace as changed

    from stereo_obstacles.obstacles import measure_obstacles

    ids, disparity, labels, left = _world(right_id=4)
    measured = measure_obstacles(ids, disparity, RIG, GROUND)
    filled_ids, filled = _fill((measured.id_map, disparity, labels, left))
    no_depth = np.where(filled_ids != measured.id_map, np.float32(-20.0), filled)               # d + doffs < 0
    assert widen_obstacles(measured, filled_ids, no_depth, RIG, 1.0) == measured
    infinite = changed(RIG, doffs_px=-float(RIG.focal_baseline_px_m / 4.0))                   # d + doffs = 0 at 4 m
    assert widen_obstacles(measured, filled_ids, filled, infinite, 1.0) == measured
    with pytest.raises(InvalidInputError, match="calibration must be"):
        widen_obstacles(measured, filled_ids, filled, None, 1.0)
    with pytest.raises(InvalidInputError, match="must have the id map's shape"):
        widen_obstacles(measured, filled_ids[:, :5], filled, RIG, 1.0)
