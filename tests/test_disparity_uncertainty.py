"""Disparity uncertainty from the pair's noise and the window's texture, and its use in the pipeline."""

from __future__ import annotations

import numpy as np
import pytest

from stereo_obstacles.disparity_uncertainty import disparity_sigma_px, pair_noise_sigma
from stereo_obstacles.errors import InvalidInputError


def _pair(noise: float, disparity: float = 5.0, seed: int = 3):
    """A random scene seen at a constant subpixel disparity, with independent noise in each image."""
    rng = np.random.default_rng(seed)
    scene = np.cumsum(rng.normal(0, 6, (80, 160)), axis=1).astype(np.float64)  # smooth rows: linear interpolation is exact enough
    xs = np.arange(20, 140, dtype=np.float64)
    left = np.stack([np.interp(xs, np.arange(160), row) for row in scene])
    right = np.stack([np.interp(xs + disparity, np.arange(160), row) for row in scene])
    left = (left + rng.normal(0, noise, left.shape)).astype(np.float32)
    right = (right + rng.normal(0, noise, right.shape)).astype(np.float32)
    d = np.full(left.shape, disparity, np.float32)
    d[:, :6] = np.nan  # no right pixel
    return left, right, d


@pytest.mark.parametrize("noise", [0.5, 2.0, 5.0])
def test_pair_noise_is_recovered_from_the_residual_of_correct_matches(noise):
    left, right, d = _pair(noise)
    assert pair_noise_sigma(left, right, d) == pytest.approx(noise, rel=0.15)


def test_a_few_wrong_matches_move_the_noise_estimate_little():
    left, right, d = _pair(2.0)
    wrong = d.copy()
    wrong[:, 6:18] += 3.0  # a tenth of the matches three pixels off (their residuals are large)
    assert pair_noise_sigma(left, right, wrong) == pytest.approx(2.0, rel=0.2)


def test_nothing_matched_gives_zero_noise_and_bad_shapes_are_refused():
    left, right, _ = _pair(1.0)
    assert pair_noise_sigma(left, right, np.full(left.shape, np.nan, np.float32)) == 0.0
    with pytest.raises(InvalidInputError, match="one 2-D shape"):
        pair_noise_sigma(left, right[:, 1:], np.zeros(left.shape, np.float32))


def _slow_sigma(grey: np.ndarray, noise: float, cap: float) -> np.ndarray:
    """The formula written out: 5x5 sums of squared central differences (the image's border
    replicated for the differences, the differences' border replicated for the sums)."""
    h, w = grey.shape
    wide = np.pad(grey.astype(np.float64), 1, mode="edge")
    gradient = np.pad((wide[1:-1, 2:] - wide[1:-1, :-2]) / 2, 2, mode="edge")
    out = np.empty((h, w))
    for y in range(h):
        for x in range(w):
            energy = 0.0
            for dy in range(5):
                for dx in range(5):
                    energy += gradient[y + dy, x + dx] ** 2
            signal = energy - 25 * noise ** 2 / 2
            out[y, x] = cap if signal <= 0 else min(np.sqrt(2) * noise / np.sqrt(signal), cap)
    return out


def test_disparity_sigma_matches_the_written_out_formula():
    grey = np.random.default_rng(5).uniform(0, 30, (12, 17)).astype(np.float32)
    grey[:, 8:] = 100.0  # a flat half: no texture, the cap
    got = disparity_sigma_px(grey, 2.0, max_sigma_px=0.75)
    np.testing.assert_allclose(got, _slow_sigma(grey, 2.0, 0.75), rtol=1e-4, atol=1e-6)
    assert got[:, 12:].min() == pytest.approx(0.75)
    assert not disparity_sigma_px(grey, 0.0, max_sigma_px=0.75).any()  # no noise: every match certain


def test_disparity_sigma_refuses_bad_arguments():
    with pytest.raises(InvalidInputError, match="noise_sigma"):
        disparity_sigma_px(np.zeros((5, 5), np.float32), -1.0, max_sigma_px=1.0)
    with pytest.raises(InvalidInputError, match="max_sigma_px"):
        disparity_sigma_px(np.zeros((5, 5), np.float32), 1.0, max_sigma_px=0.0)


def test_noisy_far_ground_is_not_raised_into_obstacles():
    """Scene 1 with 2 grey levels of sensor noise: without the significance test, patches of far
    ground matched about a pixel too near stand above the ground plane as obstacles."""
    from stereo_obstacles.detection_evaluation import compare_with_truth
    from stereo_obstacles.pipeline import DetectionConfig, detect
    from stereo_obstacles.synthetic import RenderOptions, random_scene, render_pair

    pair = render_pair(random_scene(1, width_px=640, height_px=480), RenderOptions(noise_sigma=2.0))
    outcomes = {}
    for significance in (None, 3.0):
        result = detect(pair.left, pair.right, pair.calibration, config=DetectionConfig(standing_significance=significance))
        comparisons, alarms = compare_with_truth(result.obstacles, pair.instances, pair.labels, pair.obstacles)
        outcomes[significance] = (comparisons, alarms)
    assert len(outcomes[None][1]) >= 5  # the test does something on this scene
    comparisons, alarms = outcomes[3.0]
    assert alarms == []
    assert all(c.detected_id is not None for c in comparisons if c.true_distance_m and c.true_distance_m < 10)
    with pytest.raises(InvalidInputError, match="standing_significance"):
        DetectionConfig(standing_significance=-1.0)


def test_match_residuals_kernel_equals_its_numpy_definition():
    from stereo_obstacles._disparity_uncertainty_kernel import match_residuals_kernel

    rng = np.random.default_rng(9)
    left, right = (rng.uniform(0, 255, (23, 31)).astype(np.float32) for _ in range(2))
    d = rng.uniform(-2.0, 33.0, (23, 31)).astype(np.float32)  # some fall outside the right image
    d[rng.random(d.shape) < 0.2] = np.nan
    expected = []
    for y in range(0, 23, 4):
        for x in range(31):
            if np.isfinite(d[y, x]):
                x_right = x - float(d[y, x])
                x0 = int(np.floor(x_right))
                if 0 <= x0 and x0 + 1 < 31:
                    frac = x_right - x0
                    expected.append(left[y, x] - (right[y, x0] * (1 - frac) + right[y, x0 + 1] * frac))
    got = match_residuals_kernel(left, right, d, 4)
    assert 0 < got.size < 6 * 31
    np.testing.assert_allclose(got, expected, rtol=1e-6, atol=1e-4)
