"""The check that warns before matching a pair that is not rectified."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from stereo_obstacles.errors import ImageMismatchError, InvalidInputError
from stereo_obstacles.feature_matching import match_features
from stereo_obstacles.rectification_check import check_rectification, refuse_swapped
from stereo_obstacles.synthetic import RenderOptions, RightCameraError, default_scene, render_pair


@pytest.fixture(scope="module")
def pairs():
    scene = default_scene(160, 120)
    return (render_pair(scene),
            render_pair(scene, RenderOptions(right_error=RightCameraError(rotation_deg=(0.8, 0.0, 0.5),
                                                                          vertical_offset_px=3.0))))


def test_rectified_pair_passes_quietly(pairs, caplog):
    with caplog.at_level(logging.WARNING):
        check = check_rectification(pairs[0].left, pairs[0].right)
    assert check.rectified is True and check.offsets.median_px < 0.5
    assert not caplog.records


def test_unrectified_pair_warns(pairs, caplog):
    with caplog.at_level(logging.WARNING):
        check = check_rectification(pairs[1].left, pairs[1].right)
    assert check.rectified is False and check.offsets.median_px > 1.0
    assert "does not look rectified" in caplog.text
    assert check.to_dict()["vertical_offset"]["n_points"] == check.offsets.n_points


def test_plain_images_cannot_be_judged(caplog):
    flat = np.full((60, 80, 3), 90, np.uint8)
    with caplog.at_level(logging.WARNING):
        assert check_rectification(flat, flat).rectified is None
    assert "the pair could not be checked: only 0 feature matches" in caplog.text
    caplog.clear()
    with caplog.at_level(logging.WARNING):
        check_rectification(flat, flat, warn=False)
    assert not caplog.records


def test_a_genuine_pair_with_few_matches_on_one_row_is_not_warned_of(caplog):
    # synthetic scene 9 gives detect's check 7 matches, 95 % within 1.31 px: "the results mean
    # nothing" was wrong
    from stereo_obstacles.pipeline import pair_rectification_check
    from stereo_obstacles.synthetic import random_scene

    pair = render_pair(random_scene(9))
    with caplog.at_level(logging.WARNING):
        check = pair_rectification_check(pair.left, pair.right)
    assert check.rectified is None and 3 <= check.offsets.n_points < 12 and check.offsets.p95_px <= 1.5
    assert not caplog.records
    # at 1920x1440 the check matches a copy shrunk 3x: one of its pixels is 3 full-size ones (review)
    large = render_pair(random_scene(9, width_px=1920, height_px=1440))
    with caplog.at_level(logging.WARNING):
        check = pair_rectification_check(large.left, large.right)
    assert check.rectified is None and check.offsets.p95_px > 1.5
    assert not caplog.records


def test_different_scenes_with_a_few_matches_near_one_row_are_warned_of(caplog):
    # scene 1's left with scene 19's right: 7 matches with a median 0.8 px apart but a 95th
    # percentile of 168 px passed as one row by the median (found by a review)
    from stereo_obstacles.pipeline import pair_rectification_check
    from stereo_obstacles.synthetic import random_scene

    with caplog.at_level(logging.WARNING):
        check = pair_rectification_check(render_pair(random_scene(1)).left, render_pair(random_scene(19)).right)
    assert 3 <= check.offsets.n_points < 12 and check.offsets.median_px <= 1.0
    assert "the results mean nothing" in caplog.text


@pytest.mark.parametrize("n, median, p95, scale, expected", [
    (7, 0.0, 1.31, 1.0, True),        # scene 9 as detect checks it
    (7, 0.0, 2.1, 3.0, True),         # scene 9 at 1920x1440, matched shrunk 3x
    (7, 0.8, 168.0, 1.0, False),      # scene 1's left with scene 19's right
    (5, 2.88, 4.8, 6.0, False),       # scene 19's left with scene 1's right at 3840x2160 (review)
    (2, 0.0, 0.0, 1.0, False),        # too few to say anything
])
def test_matches_too_few_for_a_verdict_on_one_row(n, median, p95, scale, expected):
    from stereo_obstacles.rectification_check import on_one_row
    from stereo_obstacles.rectification_quality import VerticalOffsetStats

    offsets = VerticalOffsetStats(n_points=n, median_px=median, p95_px=p95, max_px=p95, mean_signed_px=0.0)
    assert on_one_row(offsets, 1.0, scale) is expected


def test_two_images_of_different_scenes_are_warned_of(shared_dataset, caplog):
    # Cones' left with Teddy's right: 4 obstacles at "0.71 m", said only at -v (found by a review)
    from stereo_obstacles.fileio import read_image

    left = read_image(shared_dataset("middlebury2003_cones") / "imL.png", mode="color")
    right = read_image(shared_dataset("middlebury2003_teddy") / "imR.png", mode="color")
    with caplog.at_level(logging.WARNING):
        assert check_rectification(left, right).rectified is None
    assert "the results mean nothing" in caplog.text


def test_bad_arguments(pairs):
    with pytest.raises(InvalidInputError, match="threshold_px"):
        check_rectification(pairs[0].left, pairs[0].right, threshold_px=0)
    with pytest.raises(ImageMismatchError):
        check_rectification(pairs[0].left, pairs[0].right[:50])
    with pytest.raises(InvalidInputError, match="method"):
        match_features(pairs[0].left, pairs[0].right, method="surf")
    for levels in (0, 17, 2.5, True):
        with pytest.raises(InvalidInputError, match="orb_levels"):
            match_features(pairs[0].left, pairs[0].right, method="orb", orb_levels=levels)


@pytest.mark.parametrize("method, levels", [("sift", 8), ("orb", 8), ("orb", 3), ("orb", 2), ("orb", 1)])
def test_feature_matches_find_a_known_shift(method, levels):
    rng = np.random.default_rng(3)
    image = (rng.uniform(0, 255, (160, 200)) > 128).astype(np.uint8) * 255
    image = np.kron(image, np.ones((2, 2), np.uint8))
    matches = match_features(image, np.roll(image, (2, -6), axis=(0, 1)), method=method, orb_levels=levels)
    assert len(matches) > 20
    shift = np.median(matches.right_px - matches.left_px, axis=0)
    assert shift == pytest.approx([-6.0, 2.0], abs=0.5)


def test_a_12_bit_pair_in_16_bit_images_is_matched_as_its_8_bit_copy():
    """16-bit images are read by their significant bits: 12-bit data (values up to 4080) shifted
    by 8 bits was nearly black, and nothing matched."""
    rng = np.random.default_rng(3)
    image = np.kron((rng.uniform(0, 255, (160, 200)) > 128).astype(np.uint8) * 255, np.ones((2, 2), np.uint8))
    shifted = np.roll(image, (2, -6), axis=(0, 1))
    eight = match_features(image, shifted, method="orb", orb_levels=3)
    twelve = match_features(image.astype(np.uint16) * 16, shifted.astype(np.uint16) * 16, method="orb", orb_levels=3)
    assert len(twelve) == len(eight) > 20
    np.testing.assert_array_equal(twelve.left_px, eight.left_px)
    brighter = shifted.astype(np.uint16) * 16
    brighter[0, 0] = 4096                                  # one pixel of 13 bits: the pair keeps one scale
    one_scale = match_features(image.astype(np.uint16) * 16, brighter, method="orb", orb_levels=3)
    both_halved = match_features(image // 2, shifted // 2, method="orb", orb_levels=3)
    assert len(one_scale) == len(both_halved)


def test_pipeline_records_the_check(pairs, caplog):
    from stereo_obstacles.pipeline import detect

    with caplog.at_level(logging.WARNING, logger="stereo_obstacles.rectification_check"):
        result = detect(pairs[1].left, pairs[1].right, pairs[1].calibration)
    assert result.rectification_check.rectified is False
    assert "rectification_check" in result.timings_s
    assert "does not look rectified" in caplog.text


def test_swapped_pair_is_recognised_and_refused(pairs):
    check = check_rectification(pairs[0].right, pairs[0].left, method="orb", warn=False)
    assert check.swapped is True and check.negative_fraction > 0.8
    with pytest.raises(ImageMismatchError, match="look swapped"):
        refuse_swapped(check)
    as_given = check_rectification(pairs[0].left, pairs[0].right, method="orb", warn=False)
    assert as_given.swapped is False and as_given.negative_fraction < 0.2
    refuse_swapped(as_given)
    refuse_swapped(None)                                         # no check made: nothing to refuse


def test_the_swapped_warning_is_left_to_the_caller_that_refuses_the_pair(caplog):
    from stereo_obstacles.rectification_check import SWAPPED_WARNING, logger, refusing_swapped_pairs

    def warn_swapped():
        caplog.clear()
        logger.warning(SWAPPED_WARNING, 100.0, 168)
        logger.warning("the pair does not look rectified: %s", "other warnings stay")
        return caplog.text

    assert "look swapped" in warn_swapped()
    with refusing_swapped_pairs():
        with refusing_swapped_pairs():                     # nested (or a batch's concurrent pairs)
            text = warn_swapped()
            assert "look swapped" not in text and "other warnings stay" in text
        assert "look swapped" not in warn_swapped()
    assert "look swapped" in warn_swapped()
    assert logger.filters == []
