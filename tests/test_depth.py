"""Depth from disparity, its inverse, 3-D points."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.depth import (depth_to_disparity, depth_uncertainty_m, disparity_to_depth,
                                    points_from_depth)
from stereo_obstacles.errors import InvalidInputError

RIG = StereoCalibration(focal_px=700.0, cx_px=320.0, cy_px=240.0, baseline_m=0.12, width_px=640, height_px=480)


def test_known_depths():
    depth = disparity_to_depth(np.array([[84.0, 8.4, np.nan, 0.0, -3.0]], np.float32), RIG)
    np.testing.assert_allclose(depth[0, :2], [1.0, 10.0], rtol=1e-6)
    assert np.isnan(depth[0, 2:]).all()


def test_middlebury_doffs_is_added_to_disparity():
    rig = StereoCalibration(focal_px=4161.221, cx_px=1445.577, cy_px=984.686, baseline_m=0.176252,
                            width_px=2880, height_px=1988, doffs_px=209.059)
    depth = disparity_to_depth(np.array([[100.0]], np.float32), rig)
    assert depth[0, 0] == pytest.approx(4161.221 * 0.176252 / 309.059, rel=1e-6)


@settings(max_examples=50, deadline=None)
@given(hnp.arrays(np.float32, (3, 4), elements=st.floats(0.5, 200.0, width=32)),
       st.floats(-50.0, 50.0))
@example(np.full((3, 4), 1.1, np.float32), -1.1)  # d + doffs a rounding error above 0
def test_depth_disparity_round_trip(disparity, doffs):
    rig = StereoCalibration(focal_px=500.0, cx_px=2.0, cy_px=1.0, baseline_m=0.2, doffs_px=doffs)
    depth = disparity_to_depth(disparity, rig)
    back = depth_to_disparity(depth, rig)
    positive = disparity.astype(np.float64) + doffs > 0  # as disparity_to_depth computes it
    np.testing.assert_allclose(back[positive], disparity[positive], rtol=1e-4, atol=1e-3)
    assert np.isnan(back[~positive]).all()


def test_points_follow_the_pinhole_model():
    depth = np.full((480, 640), np.nan, np.float32)
    depth[240, 320] = 2.0
    depth[100, 600] = 5.0
    points = points_from_depth(depth, RIG)
    np.testing.assert_allclose(points[240, 320], [0.0, 0.0, 2.0], atol=1e-6)
    np.testing.assert_allclose(points[100, 600], [280 / 700 * 5, -140 / 700 * 5, 5.0], rtol=1e-6)
    assert np.isnan(points[0, 0]).all()


def test_uncertainty_grows_with_the_square_of_depth():
    u = depth_uncertainty_m(np.array([[1.0, 5.0]], np.float32), RIG)
    np.testing.assert_allclose(u[0], [1 / 84, 25 / 84], rtol=1e-5)


def test_bad_input_is_refused():
    with pytest.raises(InvalidInputError, match="2-D"):
        disparity_to_depth(np.zeros(3, np.float32), RIG)
    with pytest.raises(InvalidInputError, match="floating point"):
        disparity_to_depth(np.zeros((2, 2), np.uint8), RIG)


def test_depth_without_a_calibration_or_with_a_negative_error_is_refused():
    # an AttributeError from inside, and a negative uncertainty (API review, session 23)
    d = np.full((2, 2), 10.0, np.float32)
    for convert in (disparity_to_depth, depth_to_disparity, points_from_depth, depth_uncertainty_m):
        with pytest.raises(InvalidInputError, match="calibration must be a StereoCalibration .*got NoneType"):
            convert(d, None)
    for error in (-1.0, float("nan")):
        with pytest.raises(InvalidInputError, match="disparity_error_px must be a finite number >= 0"):
            depth_uncertainty_m(d, RIG, disparity_error_px=error)


def test_depth_uncertainty_takes_a_map_of_disparity_errors():
    # a per-pixel sigma map (disparity_sigma_px) was refused with its repr over lines (review)
    z = np.full((2, 2), 2.0, np.float32)
    sigma = np.array([[0.2, 0.5], [1.0, 1.0]], np.float32)
    np.testing.assert_allclose(depth_uncertainty_m(z, RIG, sigma), 4.0 / (700.0 * 0.12) * sigma, rtol=1e-6)
    with pytest.raises(InvalidInputError, match=r"^disparity_error_px: a map \(2, 2\) with values"):
        depth_uncertainty_m(z, RIG, -sigma)
    for wrong in (np.ones((3, 3)), np.ones((4, 2, 2))):                # no fit, or a larger result
        with pytest.raises(InvalidInputError, match="does not fit the depth map"):
            depth_uncertainty_m(z, RIG, wrong)
    np.testing.assert_allclose(depth_uncertainty_m(z, RIG, np.array(1.0)), depth_uncertainty_m(z, RIG, 1.0))
