"""Least-squares planes d = a x + b y + c from the sums of their points."""

from __future__ import annotations

import numpy as np
import pytest

from stereo_obstacles.plane_fit import least_squares_plane, mean_squared_residual, plane_at, plane_moments, robust_plane


def _points(seed: int, n: int = 300):
    rng = np.random.default_rng(seed)
    xs, ys = rng.integers(0, 1242, n).astype(np.float64), rng.integers(0, 375, n).astype(np.float64)
    return xs, ys, rng


@pytest.mark.parametrize("seed", range(3))
def test_an_exact_plane_is_recovered(seed):
    xs, ys, rng = _points(seed)
    a, b, c = rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1), rng.uniform(5, 80)
    plane = least_squares_plane(xs, ys, a * xs + b * ys + c)
    np.testing.assert_allclose(plane, (a, b, c), rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("seed", range(3))
def test_noisy_points_give_numpys_least_squares_plane_and_residuals(seed):
    xs, ys, rng = _points(seed)
    ds = 0.02 * xs - 0.05 * ys + 20 + rng.normal(0, 0.3, xs.size)
    expected, *_ = np.linalg.lstsq(np.stack([xs, ys, np.ones_like(xs)], axis=1), ds, rcond=None)
    plane = least_squares_plane(xs, ys, ds)
    np.testing.assert_allclose(plane, expected, rtol=1e-8, atol=1e-10)
    other = (0.03, -0.04, 18.0)
    residual = ds - (other[0] * xs + other[1] * ys + other[2])
    moments = plane_moments(xs, ys, ds)
    assert moments.shape == (10,)
    assert mean_squared_residual(moments, other) == pytest.approx((residual ** 2).mean(), rel=1e-8)


def test_the_sums_of_two_sets_add_up_to_those_of_their_union():
    xs, ys, rng = _points(5)
    ds = rng.uniform(1, 60, xs.size)
    whole = plane_moments(xs, ys, ds)
    parts = plane_moments(xs[:100], ys[:100], ds[:100]) + plane_moments(xs[100:], ys[100:], ds[100:])
    np.testing.assert_allclose(parts, whole, rtol=1e-12)


@pytest.mark.parametrize("xs, ys", [
    ([], []), ([3.0], [4.0]),
    ([1.0, 2.0, 3.0, 4.0], [7.0, 7.0, 7.0, 7.0]),         # one row
    ([5.0, 5.0, 5.0], [1.0, 2.0, 9.0]),                   # one column
    ([0.0, 1.0, 2.0, 3.0], [0.0, 2.0, 4.0, 6.0]),         # one slanted line
    ([0.0, 100.0, 200.0, 300.0], [0.0, 200.01, 400.0, 599.99]),      # a line but for 0.01 px
])
def test_points_that_pin_no_plane_down_give_none(xs, ys):
    xs, ys = np.array(xs), np.array(ys)
    assert least_squares_plane(xs, ys, np.ones_like(xs)) is None
    assert np.isnan(mean_squared_residual(plane_moments(xs, ys, xs), (0.0, 0.0, 0.0))) == (xs.size == 0)


def test_the_robust_plane_ignores_a_tenth_of_outliers():
    rng = np.random.default_rng(7)
    xs, ys = rng.uniform(0, 100, 2000), rng.uniform(0, 80, 2000)
    d = 5.0 + 0.02 * xs - 0.01 * ys
    d[:200] += 5.0
    np.testing.assert_allclose(robust_plane(xs, ys, d), (0.02, -0.01, 5.0), atol=1e-9)
    np.testing.assert_allclose(plane_at((0.02, -0.01, 5.0), np.array([10.0]), np.array([20.0])), [5.0])


def test_a_robust_plane_needs_enough_points_that_pin_it_down():
    xs = np.arange(100, dtype=np.float64)
    assert robust_plane(xs, np.zeros(100), xs * 0.1) is None              # one row: no slope in y
    assert robust_plane(xs[:20], xs[:20] % 7, xs[:20]) is None             # fewer than MIN_ROBUST_POINTS
