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
    """Pixel by pixel with ``similarity_at``: climb from the rounded estimate to the better
    neighbour while it is better and within ``radius`` of the start."""
    h, w = estimate.shape
    out = np.full((h, w), np.nan, np.float32)

    def sim(y, x, d):
        if d < d_min or d > d_max or d > x or x - d >= w:
            return np.nan
        return float(similarity_at(inputs, np.array([y]), np.array([x]), np.array([x - d]))[0])

    for y in range(h):
        for x in range(w):
            if np.isnan(estimate[y, x]):
                continue
            start = int(np.floor(estimate[y, x] + 0.5))
            d = start
            while True:
                c, cm, cp = sim(y, x, d), sim(y, x, d - 1), sim(y, x, d + 1)
                if cm > c and cm >= cp and d - 1 >= start - radius:
                    d -= 1
                elif cp > c and d + 1 <= start + radius:
                    d += 1
                else:
                    break
            if c >= tau:
                out[y, x] = d + parabola_offset(np.float32(cm), np.float32(c), np.float32(cp))
    return out


@pytest.fixture(scope="module")
def textured_pair():
    rng = np.random.default_rng(3)
    right = rng.uniform(0, 255, (18, 40)).astype(np.float32)
    right = (right + np.roll(right, 1, axis=1)) / 2  # smoother, so that the similarity has slopes
    left = np.roll(right, 5, axis=1)
    left[:, 20:] = np.roll(right, 7, axis=1)[:, 20:]  # two surfaces: disparity 5 then 7
    return prepare_similarity(left, right)


@pytest.mark.parametrize("radius", [0, 1, 2])
def test_agrees_with_the_slow_reference(textured_pair, radius):
    rng = np.random.default_rng(radius)
    estimate = rng.uniform(-1, 12, textured_pair.shape).astype(np.float32)
    estimate[rng.random(estimate.shape) < 0.2] = np.nan
    refined = refine_disparity(textured_pair, estimate, tau=0.3, d_min=0, d_max=10, radius=radius)
    expected = _reference(textured_pair, estimate, 0.3, 0, 10, radius)
    np.testing.assert_array_equal(np.isnan(refined.disparity), np.isnan(expected))
    np.testing.assert_allclose(refined.disparity, expected, atol=1e-4)
    matched = refined.integer_disparity >= 0
    np.testing.assert_array_equal(matched, np.isfinite(refined.disparity))
    assert np.all(np.abs(refined.disparity[matched] - refined.integer_disparity[matched]) <= 0.5)


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
