"""Robust ground plane fit in (x, y, disparity)."""

from __future__ import annotations

import numpy as np
import pytest

from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.ground_plane import (GroundPlane, PlaneFitParameters, fit_ground_plane,
                                           fit_plane_points)


def _scene(seed=0):
    """A 120x160 disparity map: ground plane + noise, a box in front, a wall behind, holes."""
    rng = np.random.default_rng(seed)
    ys, xs = np.mgrid[0:120, 0:160]
    disparity = 0.02 * xs + 0.3 * ys - 10.0 + rng.normal(0.0, 0.2, xs.shape)
    disparity[60:90, 40:80] = 40.0                     # an obstacle: much closer
    disparity[:40] = 3.0                               # a fronto-parallel wall (b = 0)
    disparity[rng.random(xs.shape) < 0.3] = np.nan     # sparse, like LiDAR ground truth
    return disparity.astype(np.float32)


def test_recovers_plane_despite_obstacle_wall_and_holes():
    plane = fit_ground_plane(_scene())
    assert plane.a == pytest.approx(0.02, abs=2e-3)
    assert plane.b == pytest.approx(0.3, abs=2e-3)
    assert plane.c == pytest.approx(-10.0, abs=0.3)
    assert plane.rms_px < 0.3
    assert 0.3 < plane.inlier_fraction < 0.8


def test_a_wall_filling_the_view_is_no_ground_even_though_a_tilted_plane_covers_it():
    """Constant disparity (a wall) everywhere: a candidate with the smallest ground slope allowed
    covers most points within the inlier threshold, but the points fit a flat plane far better."""
    rng = np.random.default_rng(2)
    wall = (20.0 + rng.normal(0.0, 0.1, (375, 400))).astype(np.float32)
    with pytest.raises(InvalidInputError, match="does not slope like a ground"):
        fit_ground_plane(wall)
    ground_and_wall = _scene()                     # a ground with a wall among its points still fits
    assert fit_ground_plane(ground_and_wall).b == pytest.approx(0.3, abs=2e-3)


def test_residual_map_sign_and_nan():
    d = _scene()
    plane = fit_ground_plane(d)
    residual = plane.residual_map(d)
    assert residual.dtype == np.float32 and residual.shape == d.shape
    assert np.nanmedian(residual[60:90, 40:80]) > 10.0          # the box is in front
    assert np.isnan(residual[np.isnan(d)]).all()


def test_mask_limits_the_points():
    d = _scene()
    mask = np.zeros(d.shape, bool)
    mask[:40] = True                                     # only the wall: no ground-like slope
    with pytest.raises(InvalidInputError, match="plane"):
        fit_ground_plane(d, mask=mask)
    wall = fit_ground_plane(d, mask=mask, params=PlaneFitParameters(min_slope_y=None))
    assert wall.c == pytest.approx(3.0, abs=1e-6) and abs(wall.b) < 1e-6


def test_disparity_at_broadcasts():
    plane = GroundPlane(a=1.0, b=2.0, c=3.0)
    assert plane.disparity_at(1.0, 1.0) == pytest.approx(6.0)
    assert plane.disparity_at(np.arange(3), 0).tolist() == [3.0, 4.0, 5.0]
    assert plane.disparity_map(2, 3).tolist() == [[3, 4, 5], [5, 6, 7]]


def test_reproducible_with_seed():
    d = _scene(3)
    assert fit_ground_plane(d) == fit_ground_plane(d)


@pytest.mark.parametrize("args, match", [
    ((np.zeros(10), np.zeros(10), np.zeros(9)), "one length"),
    ((np.zeros(2), np.zeros(2), np.zeros(2)), "at least"),
    ((np.array([0.0, np.nan, 1.0]), np.zeros(3), np.zeros(3)), "finite"),
])
def test_rejects_bad_points(args, match):
    with pytest.raises(InvalidInputError, match=match):
        fit_plane_points(*args)


def test_rejects_bad_parameters_and_maps():
    with pytest.raises(InvalidInputError, match="inlier_threshold_px"):
        PlaneFitParameters(inlier_threshold_px=0.0)
    with pytest.raises(InvalidInputError, match="disparity"):
        fit_ground_plane(np.zeros((4, 4), np.uint8))
    with pytest.raises(InvalidInputError, match="mask"):
        fit_ground_plane(np.zeros((4, 4), np.float32), mask=np.ones((3, 3), bool))


def test_points_on_one_row_define_no_plane():
    xs = np.arange(200, dtype=float)
    with pytest.raises(InvalidInputError, match="collinear|no usable plane"):
        fit_plane_points(xs, np.full(200, 50.0), 0.01 * xs + 3.0)


def test_compiled_inlier_count_agrees_with_numpy():
    from stereo_obstacles._ground_plane_kernel import inlier_counts_kernel

    rng = np.random.default_rng(3)
    planes = rng.normal(size=(40, 3))
    x, y = rng.uniform(0, 100, 500), rng.uniform(0, 80, 500)
    d = 0.3 * x - 0.2 * y + rng.normal(0, 5, 500)
    residuals = planes[:, :1] * x + planes[:, 1:2] * y + planes[:, 2:] - d
    inside = np.abs(residuals) <= 2.0
    counts, squares = inlier_counts_kernel(planes, x, y, d, 2.0)
    assert np.array_equal(counts, inside.sum(axis=1)) and counts.max() > 0
    np.testing.assert_allclose(squares, np.where(inside, residuals ** 2, 0.0).sum(axis=1), rtol=1e-12)


def test_raised_pixels_are_those_whose_3d_points_stand_above_the_ground():
    from stereo_obstacles.calibration import StereoCalibration
    from stereo_obstacles.ground_plane import height_above_ground_m, raised_pixels

    calibration = StereoCalibration(focal_px=500.0, cx_px=320.0, cy_px=240.0, baseline_m=0.12, doffs_px=1.5,
                                    width_px=640, height_px=480)
    ground = GroundPlane(a=0.002, b=0.09, c=-20.0)
    rng = np.random.default_rng(5)
    ys, xs = np.mgrid[250:480, 0:640]
    d = (ground.disparity_at(xs, ys) + rng.uniform(-1.0, 6.0, xs.shape)).astype(np.float32)
    d[rng.random(d.shape) < 0.1] = np.nan
    disparity = np.full((480, 640), np.nan, np.float32)
    disparity[250:] = d
    mask = rng.random((480, 640)) < 0.8
    z = calibration.focal_baseline_px_m / (d.astype(np.float64) + 1.5)
    points = np.stack([(xs - 320.0) * z / 500.0, (ys - 240.0) * z / 500.0, z], axis=-1)
    heights = np.full((480, 640), np.nan)
    heights[250:] = height_above_ground_m(ground, points, calibration)
    excess = disparity - ground.disparity_map(480, 640)
    usable = mask & np.isfinite(disparity)
    expected = usable & (heights > 0.2) & (excess >= 0.5)
    got = raised_pixels(ground, disparity, mask, calibration, min_height_m=0.2, min_excess_px=0.5, strict=True)
    near_threshold = np.abs(heights - 0.2) < 1e-9                       # rounding of the two forms
    assert np.array_equal(got & ~near_threshold, expected & ~near_threshold)
    assert 0 < expected.sum() < usable.sum()
    uncalibrated = raised_pixels(ground, disparity, mask, None, min_excess_px=1.0)
    assert np.array_equal(uncalibrated, usable & (excess >= 1.0))
    per_pixel = rng.uniform(0.0, 4.0, (480, 640)).astype(np.float32)  # a threshold of its own for every pixel
    assert np.array_equal(raised_pixels(ground, disparity, mask, None, min_excess_px=per_pixel),
                          usable & (excess >= per_pixel))
    calibrated = raised_pixels(ground, disparity, mask, calibration, min_height_m=0.2, min_excess_px=per_pixel,
                               strict=True)
    expected = usable & (heights > 0.2) & (excess >= per_pixel)
    assert np.array_equal(calibrated & ~near_threshold, expected & ~near_threshold)
    with pytest.raises(InvalidInputError, match="min_excess_px"):
        raised_pixels(ground, disparity, mask, None, min_excess_px=per_pixel[1:])
    per_pixel[7, 7] = np.nan
    with pytest.raises(InvalidInputError, match="finite"):
        raised_pixels(ground, disparity, mask, None, min_excess_px=per_pixel)
