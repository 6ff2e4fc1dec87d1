"""Ground the right camera cannot see: the compiled test against a slow reference, constructed
cases, the rejection of groups, and the false alarm it removes from a rendered scene."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _evaluation_scenes import evaluation_pair
from _right_image_cover import matches_of_row, random_disparity_rows, reference_cover

from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.ground_plane import GroundPlane
from stereo_obstacles.hidden_ground import (SURFACE, HiddenGroundParameters, hidden_ground,
                                            reject_hidden_ground)
from stereo_obstacles.labels import Label


def _plane(a: float = 0.0, b: float = 0.0, c: float = 20.0) -> GroundPlane:
    return GroundPlane(a=a, b=b, c=c, n_inliers=100, inlier_fraction=1.0, rms_px=0.0)


def _reference(d: np.ndarray, mask: np.ndarray, plane: GroundPlane, params: HiddenGroundParameters) -> np.ndarray:
    """The definition, written out: the right-image cover as the visibility test builds it; for
    every occluding edge (two matches at most ``max_edge_gap_px`` apart, rising by more than
    ``min_jump_px``), the masked matches at or left of its far side whose ground (plane > 0)
    lies behind its near side, at a column covered by a surface ``min_jump_px`` nearer."""
    h, w = d.shape
    d = d.astype(float)
    hidden = np.zeros((h, w), bool)
    for y in range(h):
        xs = matches_of_row(d[y])
        cover = reference_cover(d[y], SURFACE.max_gap_px, SURFACE.surface_tolerance_px)
        for far, near in zip(xs[:-1], xs[1:]):
            if near - far > params.max_edge_gap_px or d[y, near] - d[y, far] <= params.min_jump_px:
                continue
            for x in xs:
                g = plane.a * x + plane.b * y + plane.c
                if x > far or not mask[y, x] or g <= 0 or near - x > d[y, near] - g + 0.5:
                    continue
                r = math.floor(x - g + 0.5)
                if 0 <= r < w and cover[r] > d[y, x] + params.min_jump_px:
                    hidden[y, x] = True
    return hidden


@pytest.mark.parametrize("seed", range(6))
def test_compiled_test_equals_the_reference_on_random_maps(seed):
    d = random_disparity_rows(seed, [3.0, 8.0, 14.0, 25.0], (8, 64))
    mask = np.random.default_rng(seed + 100).random(d.shape) < 0.5
    plane = _plane(a=0.01, b=1.5, c=-1.0)        # rows 0 (above the horizon) to 7 (at 9.5 px)
    for params in (HiddenGroundParameters(), HiddenGroundParameters(min_jump_px=0.5, max_edge_gap_px=3)):
        expected = _reference(d, mask, plane, params)
        assert expected.any()
        assert np.array_equal(hidden_ground(d, mask, plane, params), expected)


def _edge_row() -> np.ndarray:
    """One row: ground at 20 px, a near box from column 50 at 40 px whose first 4 columns went
    unmatched, and ground left of it matched too near (30 px) at columns 40..43."""
    d = np.full((1, 100), 20.0, np.float32)
    d[0, 50:70] = 40.0
    d[0, 50:54] = np.nan
    d[0, 40:44] = 30.0
    return d


def test_ground_matched_too_near_beside_a_near_edge_is_hidden_ground():
    d = _edge_row()
    assert np.flatnonzero(hidden_ground(d, d == 30.0, _plane())[0]).tolist() == [40, 41, 42, 43]
    # only the matches asked about, and only where the plane is below the horizon
    assert not hidden_ground(d, np.zeros(d.shape, bool), _plane()).any()
    assert not hidden_ground(d, d == 30.0, _plane(c=-5.0)).any()


def test_the_limits_are_strict():
    # an edge rises by more than 2 px, the cover is more than 2 px nearer than the match, and the
    # plane lies below the horizon (g > 0): each exactly at its limit hides nothing
    def row(edge_near: float, cover: float) -> np.ndarray:
        d = np.full((1, 100), np.nan, np.float32)
        d[0, 40:44] = 30.0                      # the tested matches; ground at 20 px would be at columns 20..23
        d[0, 50:53] = edge_near                 # the next match: an edge if more than 2 px nearer
        d[0, 64:81] = cover                     # 12 columns on: no edge, but it covers columns 19..36
        return d

    for edge_near, cover, hidden in ((32.0, 45.0, False), (32.25, 45.0, True), (32.25, 32.25, True)):
        d = row(edge_near, cover)
        assert hidden_ground(d, d == 30.0, _plane()).any() == hidden
    d = row(32.0, 32.0)
    d[0, 50:53] = 20.0                          # far side of an edge to ...
    d[0, 53:66] = 32.0                          # ... a near side exactly 2 px nearer than the match
    assert not hidden_ground(d, d == 30.0, _plane()).any()
    d[0, 53:66] = 32.25
    assert hidden_ground(d, d == 30.0, _plane()).any()
    assert not hidden_ground(d, d == 30.0, _plane(), HiddenGroundParameters(min_jump_px=2.25)).any()
    far = np.full((1, 100), np.nan, np.float32)
    far[0, 40:44] = 5.0                         # matched beside a near side at 12 px (right-image columns 40..58)
    far[0, 52:71] = 12.0
    assert not hidden_ground(far, far == 5.0, _plane(c=0.0)).any()   # the horizon: no ground to hide
    assert np.flatnonzero(hidden_ground(far, far == 5.0, _plane(c=1.0))[0]).tolist() == [41, 42, 43]


def test_no_edge_or_a_far_edge_hides_nothing():
    d = _edge_row()
    wide_gap = d.copy()
    wide_gap[0, 44:54] = np.nan                 # 10 unmatched columns: the edge is 11 columns wide
    assert not hidden_ground(wide_gap, wide_gap == 30.0, _plane()).any()
    assert hidden_ground(wide_gap, wide_gap == 30.0, _plane(), HiddenGroundParameters(max_edge_gap_px=11)).any()
    receding = np.full((1, 100), np.nan, np.float32)
    receding[0, 20:80] = np.linspace(22.0, 34.0, 60)   # a face receding to the left, no jump anywhere
    assert not hidden_ground(receding, np.isfinite(receding), _plane()).any()


def test_ground_the_right_camera_sees_beside_a_thin_pole_is_not_hidden():
    d = np.full((1, 100), 20.0, np.float32)
    d[0, 60:63] = 40.0                           # a pole 3 columns wide: right-image columns 20..22
    d[0, 56:60] = 30.0                           # ground left of it at right-image columns 36..39, open
    assert not hidden_ground(d, d == 30.0, _plane()).any()


def test_hidden_ground_checks_its_arguments():
    d = _edge_row()
    for args, message in (((d, (d == 30.0).astype(np.uint8), _plane()), "mask must be a bool map"),
                          ((d[0], d[0] == 30.0, _plane()), "disparity must be a 2-D"),
                          ((d.astype(np.complex64), d == 30.0, _plane()), "disparity must be floating point"),
                          ((d, d == 30.0, None), "ground must be a GroundPlane"),
                          ((d, d == 30.0, _plane(), {}), "params must be HiddenGroundParameters")):
        with pytest.raises(InvalidInputError, match=message):
            hidden_ground(*args)
    groups = np.zeros(d.shape, np.int32)
    labels = np.zeros(d.shape, np.uint8)
    for args, message in (((groups.astype(float), d, labels, _plane()), "groups must hold integers"),
                          ((groups, d, labels.astype(str), _plane()), "labels be uint8"),
                          ((groups, d.astype(str), labels, _plane()), "disparity must be floating point"),
                          ((groups, d, labels, "plane"), "ground must be a GroundPlane")):
        with pytest.raises(InvalidInputError, match=message):
            reject_hidden_ground(*args)
    for kwargs, message in (({"min_jump_px": -1.0}, "min_jump_px must be in"),
                            ({"min_jump_px": math.nan}, "min_jump_px must be in"),
                            ({"max_edge_gap_px": 0}, "max_edge_gap_px must be an integer"),
                            ({"max_edge_gap_px": 2.0}, "max_edge_gap_px must be an integer"),
                            ({"min_hidden_share": 1.5}, "min_hidden_share must be in")):
        with pytest.raises(InvalidInputError, match=message):
            HiddenGroundParameters(**kwargs)


def test_groups_mostly_of_ground_coloured_hidden_ground_are_rejected_with_their_reason():
    disparity = np.repeat(_edge_row(), 8, axis=0)
    groups = np.zeros(disparity.shape, np.int32)
    groups[0:4, 40:44] = 3                       # 16 hidden pixels ...
    groups[0:4, 0:4] = 3                         # ... and 16 open ones: half, rejected
    groups[4:8, 40:44] = 7                       # 16 hidden ...
    groups[4:8, 0:5] = 7                         # ... and 20 open ones, 4 of them unmatched: half, rejected
    disparity[4, 0:4] = np.nan
    groups[0:8, 6:12] = 9                        # all open: kept
    labels = np.full(disparity.shape, Label.GROUND.value, np.uint8)
    kept, rejected = reject_hidden_ground(groups, disparity, labels, _plane())
    assert np.array_equal(kept, np.where(groups == 9, 9, 0))
    assert [(r.box_px, r.pixel_count) for r in rejected] == [((0, 0, 44, 4), 32), ((0, 4, 44, 8), 36)]
    assert "cannot see (16 of 32 matched pixels)" in rejected[1].reason
    # a little more open ground, or phase 1's colour calling the pixels obstacle, keeps a group
    more = groups.copy()
    more[4, 5] = 7
    assert [r.box_px for r in reject_hidden_ground(more, disparity, labels, _plane())[1]] == [(0, 0, 44, 4)]
    coloured = np.where(groups == 3, Label.OBSTACLE.value, labels).astype(np.uint8)
    assert [r.box_px for r in reject_hidden_ground(groups, disparity, coloured, _plane())[1]] == [(0, 4, 44, 8)]
    huge = groups.astype(np.int64) * 2 ** 40    # numbers far beyond the pixel count: counted all the same
    kept_huge, rejected_huge = reject_hidden_ground(huge, disparity, labels, _plane())
    assert np.array_equal(kept_huge, np.where(groups == 9, 9 * 2 ** 40, 0)) and rejected_huge == rejected
    same, none = reject_hidden_ground(groups, disparity, labels, _plane(), HiddenGroundParameters(min_hidden_share=0.6))
    assert same is groups and none == ()
    with pytest.raises(InvalidInputError, match="same 2-D shape"):
        reject_hidden_ground(groups, disparity[:, :50], labels, _plane())


def test_the_shadow_beside_a_near_box_is_no_longer_an_obstacle(monkeypatch):
    # seed 244: ground and shadow left of a box 1.54 m away, matched at 34.6 px between the ground's
    # 26.7 and the box's 43 (its first columns unmatched), was reported as an obstacle at 1.89 m
    from stereo_obstacles.detection_evaluation import compare_with_truth
    from stereo_obstacles.pipeline import DetectionConfig, detect

    pair = evaluation_pair(244)

    def run(config: DetectionConfig):
        result = detect(pair.left, pair.right, pair.calibration, config=config)
        comparisons, alarms = compare_with_truth(result.obstacles, pair.instances, pair.labels, pair.obstacles,
                                                 seen_by_both=pair.nonocc)
        return result, comparisons, alarms

    result, comparisons, alarms = run(DetectionConfig())
    before, before_comparisons, before_alarms = run(DetectionConfig(hidden_ground=None))
    assert [a.lies_on for a in before_alarms] == ["shadow"]
    assert alarms == []
    assert [c.detected_distance_m for c in comparisons] == [c.detected_distance_m for c in before_comparisons]
    assert all(c.detected_distance_m is not None for c in comparisons)
    phantom = next(o for o in before.obstacles.obstacles if o.id == before_alarms[0].detected_id)
    hidden = [g for g in result.obstacles.rejected if "right camera cannot see" in g.reason]
    assert [(g.box_px, g.pixel_count) for g in hidden] == [(phantom.box_px, phantom.pixel_count)]
    # without trusted colour labels no pixel is known to be of ground colour: the test is not made
    import stereo_obstacles.pipeline as pipeline

    fitted = pipeline._ground_plane
    monkeypatch.setattr(pipeline, "_ground_plane", lambda *args: (fitted(*args)[0], False))
    untrusted, _, _ = run(DetectionConfig())
    assert not any("right camera cannot see" in g.reason for g in untrusted.obstacles.rejected)
