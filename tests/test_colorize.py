"""Disparity and depth pictures."""

from __future__ import annotations

import numpy as np
import pytest

from stereo_obstacles.colorize import color_bar, colorize_depth, colorize_disparity
from stereo_obstacles.errors import InvalidInputError


def test_disparity_picture_invalid_black_and_range():
    d = np.array([[np.nan, 0.0, 10.0, 20.0]], np.float32)
    rgb = colorize_disparity(d, 0, 20)
    assert rgb.shape == (1, 4, 3) and rgb.dtype == np.uint8
    assert rgb[0, 0].tolist() == [0, 0, 0]
    assert not np.array_equal(rgb[0, 1], rgb[0, 3])
    assert np.array_equal(colorize_disparity(d)[0, 3], rgb[0, 3])   # default range = valid range
    with pytest.raises(InvalidInputError, match="range"):
        colorize_disparity(d, 5, 5)


def test_depth_picture_near_bright_far_dark():
    rgb = colorize_depth(np.array([[0.5, 9.5, np.inf]], np.float32), max_m=10)
    assert rgb[0, 0].sum() > rgb[0, 1].sum()
    assert rgb[0, 2].tolist() == [0, 0, 0]
    with pytest.raises(InvalidInputError, match="max_m"):
        colorize_depth(np.zeros((2, 2)), 0)


def test_color_bar():
    bar = color_bar(0, 64, height=10, width=3)
    assert bar.shape == (10, 3, 3)
    assert not np.array_equal(bar[0], bar[-1])
