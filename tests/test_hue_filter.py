"""The 7x7 median on hue: circular, ignoring invalid pixels, equal to a naive masked median."""

from __future__ import annotations

import numpy as np
import pytest

from stereo_obstacles.colour import hue_difference
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.hue_filter import median_hue_within, median_within, window_counts


def _naive_median_distance(hue: np.ndarray, reference: float, size: int) -> np.ndarray:
    """Lower median of |circular hue distance| over the valid pixels of each window (NaN if none)."""
    r = size // 2
    distance = np.abs(hue_difference(hue, reference))
    out = np.full(hue.shape, np.nan)
    for y, x in np.ndindex(hue.shape):
        window = distance[max(0, y - r):y + r + 1, max(0, x - r):x + r + 1]
        values = np.sort(window[np.isfinite(window)])
        if values.size:
            out[y, x] = values[(values.size - 1) // 2]
    return out


@pytest.mark.parametrize("size", [3, 7])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_equals_naive_masked_median(size, seed):
    rng = np.random.default_rng(seed)
    hue = rng.uniform(0.0, 360.0, size=(23, 19)).astype(np.float32)
    hue[rng.random(hue.shape) < 0.4] = np.nan
    hue[:6, :6] = np.nan                  # a window with no valid hue at all
    reference, threshold = 350.0, 60.0
    within, has_hue = median_hue_within(hue, reference, threshold, size=size)
    median = _naive_median_distance(hue, reference, size)
    np.testing.assert_array_equal(has_hue, np.isfinite(median))
    np.testing.assert_array_equal(within, np.isfinite(median) & (median <= threshold))
    assert not has_hue[0, 0]


def test_wrap_around_zero():
    # ground hue straddles 0/360: half the pixels at 355, half at 6 degrees
    hue = np.where(np.indices((15, 15)).sum(axis=0) % 2 == 0, 355.0, 6.0).astype(np.float32)
    within, _ = median_hue_within(hue, 0.0, 10.0)
    assert within.all()
    # a raw (non-circular) median would give ~180 or ~6/355 values; reference 180 must not match
    far, _ = median_hue_within(hue, 180.0, 10.0)
    assert not far.any()


def test_invalid_pixels_do_not_vote():
    hue = np.full((9, 9), 120.0, dtype=np.float32)
    hue[::2, :] = np.nan                   # more than half of each window has no hue
    within, has_hue = median_hue_within(hue, 120.0, 5.0)
    assert within.all() and has_hue.all()


def test_thin_noise_is_removed_but_a_block_is_kept():
    hue = np.full((30, 30), 100.0, dtype=np.float32)
    hue[10, :] = 250.0                     # one-pixel line of a wrong hue: filtered out
    hue[18:26, 18:26] = 250.0              # an 8x8 object: kept in its interior
    within, _ = median_hue_within(hue, 100.0, 15.0)
    assert within[10].all()
    assert not within[20:24, 20:24].any()


def test_window_counts_border_counts_only_image_pixels():
    counts = window_counts(np.ones((10, 12), np.uint8), size=7)
    assert counts.dtype == np.uint16
    assert counts[0, 0] == 16 and counts[5, 5] == 49 and counts[0, 5] == 28


def test_median_within_requires_close_to_imply_valid():
    close = np.ones((4, 4), bool)
    valid = np.zeros((4, 4), bool)
    with pytest.raises(InvalidInputError, match="imply"):
        median_within(close, valid)


@pytest.mark.parametrize("kwargs, match", [
    ({"size": 4}, "odd"),
    ({"size": 0}, "odd"),
])
def test_rejects_bad_size(kwargs, match):
    with pytest.raises(InvalidInputError, match=match):
        median_hue_within(np.zeros((5, 5), np.float32), 0.0, 10.0, **kwargs)


def test_rejects_bad_threshold_and_array():
    with pytest.raises(InvalidInputError, match="threshold"):
        median_hue_within(np.zeros((5, 5), np.float32), 0.0, 200.0)
    with pytest.raises(InvalidInputError, match="hue_deg"):
        median_hue_within(np.zeros((5, 5), np.uint8), 0.0, 10.0)
