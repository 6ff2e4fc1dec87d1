"""Speckle removal: the compiled flood fill against a slow reference, known answers, errors."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.speckles import disparity_regions, speckle_mask


def _reference_mask(disparity, max_size, max_difference):
    """Slow and plain: label every region by a depth-first walk over a Python set."""
    h, w = disparity.shape
    removed = np.zeros((h, w), bool)
    seen = set()
    for start in np.ndindex(h, w):
        if start in seen or not np.isfinite(disparity[start]):
            continue
        region, todo = [], [start]
        seen.add(start)
        while todo:
            y, x = todo.pop()
            region.append((y, x))
            for ny, nx in ((y - 1, x), (y + 1, x), (y, x - 1), (y, x + 1)):
                if (0 <= ny < h and 0 <= nx < w and (ny, nx) not in seen
                        and abs(float(disparity[ny, nx]) - float(disparity[y, x])) <= max_difference):
                    seen.add((ny, nx))
                    todo.append((ny, nx))
        if len(region) <= max_size:
            for p in region:
                removed[p] = True
    return removed


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), h=st.integers(1, 14), w=st.integers(1, 14),
       max_size=st.integers(0, 30), max_difference=st.sampled_from([0.0, 0.5, 1.0, 2.5]))
def test_agrees_with_the_slow_reference(seed, h, w, max_size, max_difference):
    rng = np.random.default_rng(seed)
    d = (rng.integers(0, 5, (h, w)) + rng.choice([0.0, 0.25, 0.5], (h, w))).astype(np.float32)
    d[rng.random((h, w)) < 0.25] = np.nan
    got = speckle_mask(d, max_size_px=max_size, max_difference_px=max_difference)
    assert got.dtype == np.bool_ and got.shape == d.shape
    np.testing.assert_array_equal(got, _reference_mask(d, max_size, max_difference))


def test_island_removed_surface_kept_unmatched_untouched():
    d = np.full((20, 30), 10.0, np.float32)
    d[5:8, 5:8] = 25.0                      # a 9-pixel island of another disparity
    d[:, 25:] = np.nan
    d[12, 12] = 10.9                        # within the range: part of the surface
    mask = speckle_mask(d, max_size_px=9, max_difference_px=1.0)
    assert mask[5:8, 5:8].all()
    assert np.count_nonzero(mask) == 9
    assert not mask[:, 25:].any()
    # a region of exactly max_size + 1 pixels stays
    assert not speckle_mask(d, max_size_px=8, max_difference_px=1.0).any()


def test_regions_link_through_small_steps_only():
    ramp = np.tile(np.arange(12, dtype=np.float32), (3, 1))      # steps of 1 px along a row
    assert not speckle_mask(ramp, max_size_px=35, max_difference_px=1.0).any()
    # with steps above the range every pixel is alone: three per column, all removed
    assert speckle_mask(ramp, max_size_px=3, max_difference_px=0.5).all()


def test_extreme_settings_stay_exact():
    d = np.full((5, 5), 10.0, np.float32)
    d[2, 2] = np.inf                                   # unmatched, however large the range
    assert not speckle_mask(d, max_size_px=100, max_difference_px=1e39)[2, 2]
    assert np.count_nonzero(speckle_mask(d, max_size_px=2 ** 70, max_difference_px=1.0)) == 24
    # float64 maps are compared in float64: a step just over the range splits them
    assert speckle_mask(np.array([[100.0, 101.00000001]]), max_size_px=1, max_difference_px=1.0).all()
    assert not speckle_mask(np.array([[100.0, 101.0]]), max_size_px=1, max_difference_px=1.0).any()


@pytest.mark.parametrize("kwargs, message", [
    (dict(max_size_px=-1, max_difference_px=1.0), "max_size_px"),
    (dict(max_size_px=2.5, max_difference_px=1.0), "max_size_px"),
    (dict(max_size_px=True, max_difference_px=1.0), "max_size_px"),
    (dict(max_size_px=10, max_difference_px=-0.5), "max_difference_px"),
    (dict(max_size_px=10, max_difference_px=float("nan")), "max_difference_px"),
])
def test_bad_settings_are_refused(kwargs, message):
    with pytest.raises(InvalidInputError, match=message):
        speckle_mask(np.zeros((4, 4), np.float32), **kwargs)


@pytest.mark.parametrize("array", [np.zeros((4, 4), np.int16), np.zeros((4, 4, 1), np.float32)])
def test_bad_maps_are_refused(array):
    with pytest.raises(InvalidInputError, match="disparity"):
        speckle_mask(array, max_size_px=10, max_difference_px=1.0)


def test_a_huge_range_joins_far_apart_finite_values_only():
    d = np.array([[3e38, -3e38, np.inf]], np.float32)
    assert not speckle_mask(d, max_size_px=1, max_difference_px=1e308)[0, :2].any()   # one region of 2 stays
    with pytest.raises(InvalidInputError, match="max_difference_px"):
        speckle_mask(d, max_size_px=2, max_difference_px=10 ** 400)


def _reference_regions(disparity, max_difference):
    """Slow and plain: number the regions in raster order of their first pixel by a walk over a
    Python set."""
    h, w = disparity.shape
    labels = np.full((h, w), -1, np.int32)
    count = 0
    for start in np.ndindex(h, w):
        if labels[start] >= 0 or not np.isfinite(disparity[start]):
            continue
        labels[start] = count
        todo = [start]
        while todo:
            y, x = todo.pop()
            for ny, nx in ((y - 1, x), (y + 1, x), (y, x - 1), (y, x + 1)):
                if (0 <= ny < h and 0 <= nx < w and labels[ny, nx] < 0 and np.isfinite(disparity[ny, nx])
                        and abs(float(disparity[ny, nx]) - float(disparity[y, x])) <= max_difference):
                    labels[ny, nx] = count
                    todo.append((ny, nx))
        count += 1
    return labels, count


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), h=st.integers(1, 14), w=st.integers(1, 14),
       max_difference=st.sampled_from([0.0, 0.5, 1.0, 2.5]))
def test_regions_agree_with_the_slow_reference(seed, h, w, max_difference):
    rng = np.random.default_rng(seed)
    d = (rng.integers(0, 5, (h, w)) + rng.choice([0.0, 0.25, 0.5], (h, w))).astype(np.float32)
    d[rng.random((h, w)) < 0.25] = np.nan
    labels, count = disparity_regions(d, max_difference_px=max_difference)
    expected_labels, expected_count = _reference_regions(d, max_difference)
    assert labels.dtype == np.int32 and count == expected_count
    np.testing.assert_array_equal(labels, expected_labels)


def test_regions_refuse_what_speckles_refuse():
    with pytest.raises(InvalidInputError, match="max_difference_px"):
        disparity_regions(np.zeros((3, 3), np.float32), max_difference_px=-1.0)
    with pytest.raises(InvalidInputError, match="disparity"):
        disparity_regions(np.zeros((3, 3), np.int32), max_difference_px=1.0)
