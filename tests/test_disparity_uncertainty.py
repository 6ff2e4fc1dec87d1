"""Disparity uncertainty from the pair's noise and the window's texture, and its use in the pipeline."""

from __future__ import annotations

import numpy as np
import pytest

from stereo_obstacles.disparity_uncertainty import disparity_sigma_px, pair_noise_sigma
from stereo_obstacles.errors import InvalidInputError


def _pair(noise: float, disparity: float = 5.0, seed: int = 3):
    """A random scene seen at a constant (subpixel) disparity, with independent noise in each image.

    The scene's rows are smooth (white noise blurred by a Gaussian of 4 px), as an optical image
    is, so that interpolating between pixels is nearly exact (at most about 0.3 grey levels off
    halfway between pixels, which the estimate counts as noise)."""
    rng = np.random.default_rng(seed)
    taps = np.exp(-0.5 * (np.arange(-12, 13) / 4.0) ** 2)
    scene = np.stack([np.convolve(row, taps / taps.sum(), mode="same") for row in rng.normal(0, 120, (80, 160))])
    xs = np.arange(20, 140, dtype=np.float64)
    left = np.stack([np.interp(xs, np.arange(160), row) for row in scene])
    right = np.stack([np.interp(xs + disparity, np.arange(160), row) for row in scene])
    left = (left + rng.normal(0, noise, left.shape)).astype(np.float32)
    right = (right + rng.normal(0, noise, right.shape)).astype(np.float32)
    d = np.full(left.shape, disparity, np.float32)
    d[:, :6] = np.nan  # no right pixel
    return left, right, d


@pytest.mark.parametrize("noise, disparity", [(0.5, 5.0), (2.0, 5.0), (5.0, 5.0), (2.0, 5.25), (2.0, 5.5),
                                               (5.0, 5.5)])
def test_pair_noise_is_recovered_from_the_residual_of_correct_matches(noise, disparity):
    left, right, d = _pair(noise, disparity)
    assert pair_noise_sigma(left, right, d) == pytest.approx(noise, rel=0.15)


def test_pure_noise_at_half_pixel_positions_is_not_underestimated():
    """Interpolating halfway averages two noisy pixels: the residual's variance is 1.5, not 2,
    times one image's; the estimate accounts for it."""
    rng = np.random.default_rng(4)
    left, right = (rng.normal(100, 2, (200, 120)).astype(np.float32) for _ in range(2))
    d = np.full(left.shape, 3.5, np.float32)
    assert pair_noise_sigma(left, right, d) == pytest.approx(2.0, rel=0.08)


@pytest.mark.parametrize("gain, offset", [(1.1, 0.0), (0.8, 12.0)])
def test_a_gain_or_offset_between_the_cameras_is_not_noise(gain, offset):
    left, right, d = _pair(2.0, 5.25)
    # the right image's noise is scaled too: the estimate lies between the two images' noise
    assert 2.0 * min(1.0, gain) * 0.9 <= pair_noise_sigma(left, gain * right + offset, d) <= 2.0 * max(1.0, gain) * 1.1


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
    """Scene 8 with 2 grey levels of sensor noise: without the significance test, patches of far
    ground matched about a pixel too near stand above the ground plane as obstacles."""
    from stereo_obstacles.detection_evaluation import compare_with_truth
    from stereo_obstacles.pipeline import DetectionConfig, detect
    from stereo_obstacles.synthetic import RenderOptions, random_scene, render_pair

    pair = render_pair(random_scene(8, width_px=640, height_px=480), RenderOptions(noise_sigma=2.0))
    outcomes = {}
    for significance in (None, 3.0):
        result = detect(pair.left, pair.right, pair.calibration,
                        config=DetectionConfig(standing_significance=significance))
        comparisons, alarms = compare_with_truth(result.obstacles, pair.instances, pair.labels, pair.obstacles)
        outcomes[significance] = (comparisons, alarms, result.obstacles.rejected)
    assert len(outcomes[None][1]) >= 4  # the test does something on this scene (5 before far groups were kept)
    comparisons, alarms, rejected = outcomes[3.0]
    assert alarms == []
    # what the test keeps down is reported, not dropped silently
    assert any("3 times its uncertainty" in r.reason for r in rejected)
    assert all(c.detected_id is not None for c in comparisons if c.true_distance_m and c.true_distance_m < 10)
    with pytest.raises(InvalidInputError, match="standing_significance"):
        DetectionConfig(standing_significance=-1.0)
    for bad in (0.0, float("nan")):
        with pytest.raises(InvalidInputError, match="standing_max_sigma_px"):
            DetectionConfig(standing_max_sigma_px=bad)


def test_match_samples_kernel_equals_its_numpy_definition():
    from stereo_obstacles._disparity_uncertainty_kernel import match_samples_kernel

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
                    expected.append((left[y, x], right[y, x0] * (1 - frac) + right[y, x0 + 1] * frac,
                                     (1 - frac) ** 2 + frac ** 2))
    got = match_samples_kernel(left, right, d, 4)
    assert 0 < got[0].size < 6 * 31
    np.testing.assert_allclose(np.stack(got, axis=1), expected, rtol=1e-6, atol=1e-4)


def test_predicted_deviation_matches_the_spread_of_window_shift_estimates():
    """Monte Carlo check of the constants: over many 5x5 windows, the least-squares shift between
    two noisy views of one scene (weighted by the noise-free gradient, which makes its deviation
    exactly sqrt(2) sigma / sqrt(sum g**2)), divided by the deviation predicted from the noisy
    left image alone, has a spread of 1. Without the sqrt(2) it would be 1.56; without removing
    the noise's share of the gradient energy, 1.50."""
    import cv2

    rng = np.random.default_rng(11)
    taps = np.exp(-0.5 * (np.arange(-12, 13) / 4.0) ** 2)
    scene = np.stack([np.convolve(row, taps / taps.sum(), mode="same")
                      for row in rng.normal(0, 60, (300, 120))]).astype(np.float32)
    noise = 4.0
    left = (scene + rng.normal(0, noise, scene.shape)).astype(np.float32)
    right = (scene + rng.normal(0, noise, scene.shape)).astype(np.float32)  # true shift 0
    gradient = cv2.Sobel(scene, cv2.CV_32F, 1, 0, ksize=1, scale=0.5, borderType=cv2.BORDER_REPLICATE)
    numerator = cv2.boxFilter(gradient * (left - right), -1, (5, 5), normalize=False)
    denominator = cv2.boxFilter(gradient * gradient, -1, (5, 5), normalize=False)
    shift = (numerator / denominator)[20:-20, 20:-20]
    predicted = disparity_sigma_px(left, noise, max_sigma_px=10.0)[20:-20, 20:-20]
    usable = predicted < 0.5  # textured windows: the noise-energy correction is then reliable
    assert usable.mean() > 0.5
    assert np.std(shift[usable] / predicted[usable]) == pytest.approx(1.0, abs=0.2)
