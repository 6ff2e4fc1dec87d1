"""Full-resolution refinement: against a slow reference, known answers, threads, bad input."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.refinement import refine_disparity
from stereo_obstacles.similarity import prepare_similarity, similarity_at
from stereo_obstacles.subpixel import parabola_offset


def _reference(inputs, estimate, tau, d_min, d_max, radius):
    """Pixel by pixel with ``similarity_at``, from the definition: start at the rounded estimate
    (moved into the admissible range), go to the better admissible neighbour (the lower disparity
    on a tie) while it beats the current one; a match is where this stops at a peak within
    ``radius`` of the start with a similarity of at least ``tau``."""
    h, w = estimate.shape
    out = np.full((h, w), np.nan, np.float32)

    def sim(y, x, d):
        if d < d_min or d > min(d_max, x):
            return np.nan
        return float(similarity_at(inputs, np.array([y]), np.array([x]), np.array([x - d]))[0])

    for y in range(h):
        for x in range(w):
            if not np.isfinite(estimate[y, x]) or min(d_max, x) < d_min:
                continue
            start = int(np.clip(np.floor(estimate[y, x] + 0.5), d_min, min(d_max, x)))
            d = start
            while True:
                better = [(sim(y, x, n), -n) for n in (d - 1, d + 1) if sim(y, x, n) > sim(y, x, d)]
                if not better:
                    break
                d = -max(better)[1]
                if abs(d - start) > radius:
                    d = None
                    break
            if d is not None and sim(y, x, d) >= tau:
                out[y, x] = d + parabola_offset(np.float32(sim(y, x, d - 1)), np.float32(sim(y, x, d)),
                                                np.float32(sim(y, x, d + 1)))
    return out


@pytest.fixture(scope="module")
def textured_pair():
    rng = np.random.default_rng(3)
    right = rng.uniform(0, 255, (18, 40)).astype(np.float32)
    right = (right + np.roll(right, 1, axis=1)) / 2  # smoother, so that the similarity has slopes
    left = np.roll(right, 5, axis=1)
    left[:, 20:] = np.roll(right, 7, axis=1)[:, 20:]  # two surfaces: disparity 5 then 7
    return prepare_similarity(left, right)


@pytest.mark.parametrize("radius, d_max", [(0, 10), (1, 10), (2, 10), (2, 6)])
def test_agrees_with_the_slow_reference(textured_pair, radius, d_max):
    rng = np.random.default_rng(radius + d_max)
    estimate = rng.uniform(-2, 13, textured_pair.shape).astype(np.float32)
    estimate[rng.random(estimate.shape) < 0.2] = np.nan
    estimate[0, :3] = np.inf, -np.inf, 1e30                  # not estimates
    refined = refine_disparity(textured_pair, estimate, tau=0.3, d_min=0, d_max=d_max, radius=radius)
    expected = _reference(textured_pair, estimate, 0.3, 0, d_max, radius)
    np.testing.assert_array_equal(np.isnan(refined.disparity), np.isnan(expected))
    np.testing.assert_allclose(refined.disparity, expected, atol=1e-4)
    matched = refined.integer_disparity >= 0
    np.testing.assert_array_equal(matched, np.isfinite(refined.disparity))
    assert np.all(np.abs(refined.disparity[matched] - refined.integer_disparity[matched]) <= 0.5)
    assert matched.any() and (~matched & np.isfinite(estimate)).any()


def _smooth_pair(true_d: int):
    right = cv2.GaussianBlur(np.random.default_rng(5).uniform(0, 255, (18, 60)), (0, 0), 1.5).astype(np.float32)
    return prepare_similarity(np.roll(right, true_d, axis=1), right)


def test_a_start_at_the_top_of_the_range_climbs_down():
    inputs = _smooth_pair(4)
    refined = refine_disparity(inputs, np.full(inputs.shape, 5.0, np.float32), tau=0.5, d_min=0, d_max=5)
    assert np.all(refined.integer_disparity[:, 10:56] == 4)      # d + 1 = 6 is out of range: still climbs to 4
    over = refine_disparity(inputs, np.full(inputs.shape, 7.0, np.float32), tau=0.5, d_min=0, d_max=5)
    assert np.all(over.integer_disparity[:, 10:56] == 4)         # an estimate above the range starts at 5


def test_a_climb_stopped_by_the_radius_while_rising_is_no_match():
    inputs = _smooth_pair(7)
    for estimate, boundary in ((4.0, 6), (10.0, 8)):             # 3 px off, radius 2: the climb ends next to 7
        refined = refine_disparity(inputs, np.full(inputs.shape, estimate, np.float32), tau=0.3, d_min=0,
                                   d_max=15, radius=2)
        assert not np.any(refined.integer_disparity[:, 12:56] == boundary)
    near = refine_disparity(inputs, np.full(inputs.shape, 5.0, np.float32), tau=0.3, d_min=0, d_max=15, radius=2)
    assert np.all(near.integer_disparity[:, 12:56] == 7)


def test_estimates_two_pixels_off_find_the_true_disparity():
    """On a smooth texture (the similarity falls off over a few pixels, as in photographs)."""
    right = cv2.GaussianBlur(np.random.default_rng(5).uniform(0, 255, (18, 60)), (0, 0), 1.5).astype(np.float32)
    left = np.roll(right, 5, axis=1)
    left[:, 30:] = np.roll(right, 8, axis=1)[:, 30:]  # two surfaces: disparity 5 then 8
    h, w = left.shape
    truth = np.where(np.arange(w) < 30, 5, 8)[None, :].repeat(h, axis=0)
    estimate = (truth + np.where(np.arange(w) % 2, 2.0, -1.6)[None, :]).astype(np.float32)
    refined = refine_disparity(prepare_similarity(left, right), estimate, tau=0.5, d_min=0, d_max=15)
    inside = np.zeros((h, w), bool)
    inside[:, 10:27] = inside[:, 34:56] = True  # away from the jump and the borders
    assert np.all(refined.integer_disparity[inside] == truth[inside])


def test_the_thread_count_does_not_change_the_result(textured_pair):
    estimate = np.full(textured_pair.shape, 6.0, np.float32)
    one = refine_disparity(textured_pair, estimate, tau=0.3, d_min=0, d_max=10, n_threads=1)
    three = refine_disparity(textured_pair, estimate, tau=0.3, d_min=0, d_max=10, n_threads=3)
    np.testing.assert_array_equal(one.disparity, three.disparity)
    assert one.n_computed == three.n_computed > 0


def test_no_estimate_or_a_flat_image_gives_no_match():
    flat = prepare_similarity(np.full((12, 20), 90, np.float32), np.full((12, 20), 90, np.float32))
    refined = refine_disparity(flat, np.full((12, 20), 2.0, np.float32), tau=0.5, d_min=0, d_max=5)
    assert np.isnan(refined.disparity).all()
    empty = refine_disparity(flat, np.full((12, 20), np.nan, np.float32), tau=0.5, d_min=0, d_max=5)
    assert empty.n_computed == 0


@pytest.mark.parametrize("kwargs, message", [
    ({"estimate": np.zeros((3, 3), np.float32)}, "estimate: expected a float array of shape"),
    ({"estimate": np.zeros((18, 40), np.int32)}, "estimate: expected a float array of shape"),
    ({"tau": 1.0}, "tau: expected 0 < tau < 1"),
    ({"radius": -1}, "radius: expected an integer >= 0"),
    ({"n_threads": 0}, "n_threads: expected an integer >= 1"),
])
def test_bad_arguments_are_refused(textured_pair, kwargs, message):
    arguments = dict(estimate=np.zeros((18, 40), np.float32), tau=0.5, d_min=0, d_max=5)
    arguments.update(kwargs)
    with pytest.raises(InvalidInputError, match=message):
        refine_disparity(textured_pair, **arguments)
