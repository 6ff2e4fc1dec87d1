"""Islands matched to a repeat of the texture around them: known answers, the cases that must stay,
parameter errors, and the scene where the defect was found."""

from __future__ import annotations

import numpy as np
import pytest

from _evaluation_scenes import evaluation_pair
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.pipeline import DetectionConfig, detect
from stereo_obstacles.repeated_texture import RepeatedTextureParameters, repeat_islands

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


def test_an_island_judged_by_the_median_of_its_surroundings_not_by_one_side():
    """Wall matches face its left side only; a band 2 px behind it covers the other three:
    the surrounding disparity is the band's, 2 px from the island's, no jump. (The band, wall
    texture matched 22 px too far, matches far better at the wall's disparity: it goes.)"""
    left, right = _periodic_wall()
    disparity = np.full(left.shape, WALL_D, np.float32)
    disparity[:, :WALL_D] = np.nan
    disparity[15:37, 70:95] = WALL_D + PERIOD - 2
    disparity[20:32, 70:90] = WALL_D + PERIOD
    found = repeat_islands(disparity, left, right)
    assert not found[20:32, 70:90].any()
    assert np.count_nonzero(found) == 22 * 25 - 12 * 20


def test_an_empty_or_unmatched_map_has_no_islands():
    left, right = _periodic_wall()
    assert not repeat_islands(np.full(left.shape, np.nan, np.float32), left, right).any()
    assert repeat_islands(np.zeros((0, 0), np.float32), left[:0, :0], right[:0, :0]).shape == (0, 0)


def test_a_map_of_another_shape_than_the_images_is_refused():
    left, right = _periodic_wall()
    with pytest.raises(InvalidInputError, match="disparity: expected the images' shape"):
        repeat_islands(np.zeros((10, 10), np.float32), left, right)


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
