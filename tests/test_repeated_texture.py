"""Islands matched to a repeat of the texture around them: known answers, the cases that must stay,
parameter errors, the scene where the defect was found, and the compiled region statistics
against a slow reference."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from _evaluation_scenes import evaluation_pair
from stereo_obstacles.errors import ImageMismatchError, InvalidInputError
from stereo_obstacles.pipeline import DetectionConfig, detect
from stereo_obstacles import repeated_texture
from stereo_obstacles._repeated_texture_kernel import region_stats_kernel
from stereo_obstacles.repeated_texture import RepeatedTextureParameters, repeat_islands
from stereo_obstacles.speckles import disparity_regions

PERIOD = 24
WALL_D = 6


def _periodic_wall(rows: int = 60, periods: int = 6, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A grey pair ``(left, right)`` of a wall at :data:`WALL_D` px whose random texture repeats
    every :data:`PERIOD` columns."""
    tile = np.random.default_rng(seed).uniform(0, 255, (rows, PERIOD)).astype(np.float32)
    right = np.tile(tile, (1, periods))
    return np.roll(right, WALL_D, axis=1), right


def test_a_patch_matched_one_period_too_far_is_removed_and_nothing_else():
    left, right = _periodic_wall()
    disparity = np.full(left.shape, WALL_D, np.float32)
    disparity[20:32, 70:90] = WALL_D + PERIOD
    disparity[:, :WALL_D] = np.nan
    found = repeat_islands(disparity, left, right)
    assert found[20:32, 70:90].all()
    assert np.count_nonzero(found) == 12 * 20


def test_a_real_object_in_front_of_a_periodic_wall_stays():
    left, right = _periodic_wall()
    object_d = WALL_D + PERIOD
    texture = np.random.default_rng(1).uniform(0, 255, (12, 20)).astype(np.float32)
    left[20:32, 70:90] = texture                        # its own texture, seen by both cameras
    right[20:32, 70 - object_d:90 - object_d] = texture
    disparity = np.full(left.shape, WALL_D, np.float32)
    disparity[20:32, 70:90] = object_d
    disparity[:, :WALL_D] = np.nan
    assert not repeat_islands(disparity, left, right).any()


def test_a_horizontal_edge_matching_at_every_disparity_stays():
    """A box's top edge against the ground behind: the rows differ, the columns do not, so its
    windows match at every disparity, between the two surfaces as well."""
    left, right = _periodic_wall()
    stripes = np.repeat(np.random.default_rng(2).uniform(0, 255, (12, 1)), 60, axis=1).astype(np.float32)
    left[20:32, 60:120] = stripes
    right[20:32, 60 - 30:120 - 30] = stripes
    disparity = np.full(left.shape, WALL_D, np.float32)
    disparity[20:32, 70:90] = 30.0
    disparity[:, :WALL_D] = np.nan
    assert not repeat_islands(disparity, left, right).any()


def test_islands_too_small_too_close_or_without_surroundings_stay():
    left, right = _periodic_wall()
    base = np.full(left.shape, WALL_D, np.float32)
    base[:, :WALL_D] = np.nan
    small = base.copy()
    small[20:23, 70:73] = WALL_D + PERIOD                # 9 pixels, under min_pixels
    assert not repeat_islands(small, left, right).any()
    assert repeat_islands(small, left, right, RepeatedTextureParameters(min_pixels=9)).any()
    alone = np.full(left.shape, np.nan, np.float32)
    alone[20:32, 70:90] = WALL_D + PERIOD
    alone[25, 65:70] = WALL_D                            # 5 wall matches around it, under min_ring_pixels
    assert not repeat_islands(alone, left, right).any()
    assert repeat_islands(alone, left, right, RepeatedTextureParameters(min_ring_pixels=5)).any()
    near = base.copy()
    near[20:32, 70:90] = WALL_D + PERIOD
    assert not repeat_islands(near, left, right, RepeatedTextureParameters(min_jump_px=PERIOD + 1)).any()


def test_an_island_judged_by_the_median_of_its_surroundings_not_by_one_side(monkeypatch):
    """Strips of wall matches 1 px wide face its left and right sides, and pass the first look
    (the facing matches lie 10 px below it on average); a band 2 px behind it, above and below,
    fills most of its ring: the surrounding disparity is the band's, no jump."""
    left, right = _periodic_wall()
    disparity = np.full(left.shape, np.nan, np.float32)
    disparity[15:20, 65:95] = disparity[32:37, 65:95] = WALL_D + PERIOD - 2
    disparity[20:32, 69] = disparity[20:32, 90] = WALL_D
    disparity[20:32, 70:90] = WALL_D + PERIOD
    gathered = []
    gather = repeated_texture._island

    def recording_gather(labels, disparity, region, *rest):
        gathered.append(region)
        return gather(labels, disparity, region, *rest)

    monkeypatch.setattr(repeated_texture, "_island", recording_gather)
    found = repeat_islands(disparity, left, right)
    assert not found[20:32, 70:90].any()
    labels, _ = disparity_regions(disparity, max_difference_px=RepeatedTextureParameters().max_step_px)
    assert labels[25, 75] in gathered                              # the first look let it through


def test_the_share_of_repeating_pixels_is_judged_on_pixels_spread_over_the_island():
    """Only the island's top-left corner keeps the wall's texture: tested alone, it repeats."""
    left, right = _periodic_wall()
    rng = np.random.default_rng(3)
    left[23:32, 70:90] = rng.uniform(0, 255, (9, 20))
    left[20:23, 76:90] = rng.uniform(0, 255, (3, 14))
    disparity = np.full(left.shape, WALL_D, np.float32)
    disparity[:, :WALL_D] = np.nan
    disparity[20:32, 70:90] = WALL_D + PERIOD
    assert not repeat_islands(disparity, left, right).any()
    assert repeat_islands(disparity, left, right, RepeatedTextureParameters(max_tested_pixels=1))[20:32, 70:90].all()


def test_islands_larger_than_max_image_fraction_stay():
    left, right = _periodic_wall()
    disparity = np.full(left.shape, WALL_D, np.float32)
    disparity[20:32, 70:90] = WALL_D + PERIOD              # 240 of 8640 pixels, 2.8 %
    assert repeat_islands(disparity, left, right, RepeatedTextureParameters(max_image_fraction=0.03)).any()
    assert not repeat_islands(disparity, left, right, RepeatedTextureParameters(max_image_fraction=0.02)).any()


def test_an_empty_or_unmatched_map_has_no_islands():
    left, right = _periodic_wall()
    assert not repeat_islands(np.full(left.shape, np.nan, np.float32), left, right).any()
    assert repeat_islands(np.zeros((0, 0), np.float32), left[:0, :0], right[:0, :0]).shape == (0, 0)


def test_bad_inputs_are_refused_before_any_island_is_looked_at():
    left, right = _periodic_wall()
    with pytest.raises(InvalidInputError, match="disparity: expected the images' shape"):
        repeat_islands(np.zeros((10, 10), np.float32), left, right)
    with pytest.raises(InvalidInputError, match="disparity: expected a 2-D float array"):
        repeat_islands(np.zeros(left.shape, np.int32), left, right)
    with pytest.raises(ImageMismatchError, match="differ in size"):
        repeat_islands(np.full(left.shape, np.nan, np.float32), left, right[:, :100])


@pytest.mark.parametrize("changes, message", [
    ({"min_jump_px": 5.0}, "min_jump_px"),                 # the samples between need room
    ({"search_px": -1}, "search_px"),
    ({"min_pixels": 0}, "min_pixels"),
    ({"max_image_fraction": 1.5}, "max_image_fraction"),
    ({"min_similarity": 2.0}, "min_similarity"),
    ({"between_samples": 2.5}, "between_samples"),
])
def test_bad_parameters_are_refused(changes, message):
    with pytest.raises(InvalidInputError, match=message):
        RepeatedTextureParameters(**changes)


def test_scene_589_has_no_phantom_in_front_of_its_concrete_wall():
    """Scene 589: a concrete wall at 2.94 m whose texture repeats every 1.02 m carried patches
    matched one period too far, an obstacle at 0.33 m (``docs/pipeline.md``, session 39)."""
    pair = evaluation_pair(589)

    def nearest_m(config):
        return min(o.distance_m for o in detect(pair.left, pair.right, pair.calibration,
                                                config=config).obstacles.obstacles)

    assert nearest_m(DetectionConfig(repeated_texture=None)) < 0.5     # the defect, as it was
    assert nearest_m(DetectionConfig()) > 1.0


def _reference_region_stats(labels, disparity, max_gap):
    """Slow and plain: sizes, boxes and mean facing step of every region, each pixel looking in
    all four directions (each facing pair is then seen from both sides, as the kernel counts it)."""
    count = int(labels.max()) + 1
    sizes = np.bincount(labels[labels >= 0], minlength=count)
    boxes, steps = [], [[] for _ in range(count)]
    for region in range(count):
        ys, xs = np.nonzero(labels == region)
        boxes.append((ys.min(), xs.min(), ys.max() + 1, xs.max() + 1))
    h, w = labels.shape
    for y, x in zip(*np.nonzero(labels >= 0)):
        for dy, dx in ((0, 1), (1, 0), (0, -1), (-1, 0)):
            for k in range(1, max_gap + 1):
                ny, nx = y + k * dy, x + k * dx
                if not (0 <= ny < h and 0 <= nx < w):
                    break
                if labels[ny, nx] < 0:
                    continue
                if labels[ny, nx] != labels[y, x]:
                    steps[labels[y, x]].append(float(disparity[y, x]) - float(disparity[ny, nx]))
                break
    mean_step = np.array([np.mean(s) if s else np.nan for s in steps])
    return sizes, np.array(boxes), mean_step


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), h=st.integers(1, 12), w=st.integers(1, 12), max_gap=st.integers(1, 4))
def test_region_stats_agree_with_the_slow_reference(seed, h, w, max_gap):
    rng = np.random.default_rng(seed)
    d = (rng.integers(0, 4, (h, w)) * 3.0 + rng.choice([0.0, 0.5], (h, w))).astype(np.float32)
    d[rng.random((h, w)) < 0.3] = np.nan
    labels, count = disparity_regions(d, max_difference_px=1.0)
    assume(count > 0)
    sizes, boxes, mean_step = region_stats_kernel(labels, d, count, max_gap)
    expected_sizes, expected_boxes, expected_step = _reference_region_stats(labels, d, max_gap)
    np.testing.assert_array_equal(sizes, expected_sizes)
    np.testing.assert_array_equal(boxes, expected_boxes)
    np.testing.assert_allclose(mean_step, expected_step, equal_nan=True)


def test_windows_too_flat_to_score_do_not_count_in_the_median_between():
    """The horizontal edge above, with the right image flat where most disparities between the two
    surfaces land: those windows score nothing, and the median between is that of the windows that
    do score (the stripes, which match there too), not dragged down by the flat ones."""
    left, right = _periodic_wall()
    stripes = np.repeat(np.random.default_rng(2).uniform(0, 255, (12, 1)), 60, axis=1).astype(np.float32)
    left[20:32, 60:120] = stripes
    right[20:32, 60 - 30:120 - 30] = stripes
    right[14:38, 30:60] = 128.0                         # flat: every window touching it is undefined
    disparity = np.full(left.shape, WALL_D, np.float32)
    disparity[20:32, 66:90] = 30.0
    disparity[:, :WALL_D] = np.nan
    assert not repeat_islands(disparity, left, right).any()
