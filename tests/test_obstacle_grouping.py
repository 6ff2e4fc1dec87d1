"""The compiled cell medians and purity against their NumPy definition."""

from __future__ import annotations

import numpy as np
import pytest

from stereo_obstacles._obstacle_grouping_kernel import cell_medians_kernel


def _numpy_cells(padded, cell, min_pixels, abs_tol, rel_tol, min_pure):
    gh, gw = padded.shape[0] // cell, padded.shape[1] // cell
    blocks = padded.reshape(gh, cell, gw, cell).transpose(0, 2, 1, 3).reshape(gh, gw, cell * cell)
    counts = np.isfinite(blocks).sum(axis=2)
    medians = np.full((gh, gw), np.nan, dtype=np.float32)
    pure = np.zeros((gh, gw), dtype=bool)
    enough = counts >= min_pixels
    values = blocks[enough]
    medians[enough] = np.nanmedian(values, axis=1)
    tol = np.maximum(abs_tol, rel_tol * np.abs(medians[enough]))[:, None]
    with np.errstate(invalid="ignore"):
        agree = (np.abs(values - medians[enough][:, None]) <= tol).sum(axis=1)
    pure[enough] = agree >= min_pure * counts[enough]
    return medians, pure


@pytest.mark.parametrize("seed", range(4))
def test_cell_medians_agree_with_numpy(seed):
    rng = np.random.default_rng(seed)
    surfaces = np.kron(rng.choice([5.0, 5.5, 6.0, 9.0, 20.0], size=(6, 8)), np.ones((8, 8)))
    d = (np.roll(surfaces, 3 * seed + 3, axis=1) + rng.normal(0, 0.3, (48, 64))).astype(np.float32)  # some cells mixed
    d[rng.random(d.shape) < 0.3 + 0.15 * seed] = np.nan               # holes
    d[:8, :16][rng.random((8, 16)) < 0.95] = np.nan                     # cells with too few pixels
    d[8:16, 8:12], d[8:16, 12:16] = 5.0, 20.0                            # a cell across a depth edge
    medians, pure = cell_medians_kernel(d, 8, 6, 1.0, 0.05, 0.7)
    expected_medians, expected_pure = _numpy_cells(d, 8, 6, 1.0, 0.05, 0.7)
    np.testing.assert_array_equal(medians, expected_medians)
    np.testing.assert_array_equal(pure, expected_pure)
    assert np.isnan(medians).any() and pure.any() and (~pure & np.isfinite(medians)).any()


def test_pixel_assignment_agrees_with_numpy():
    from stereo_obstacles._obstacle_grouping_kernel import assign_pixels_kernel

    rng = np.random.default_rng(7)
    h, w, cell = 45, 61, 8                                                 # partial cells at the borders
    cell_d = rng.uniform(2.0, 40.0, (6, 8)).astype(np.float32)
    labels = rng.integers(-1, 5, (6, 8))
    pixel_cell_d = np.repeat(np.repeat(cell_d, cell, axis=0), cell, axis=1)[:h, :w]
    pixel_label = np.repeat(np.repeat(labels, cell, axis=0), cell, axis=1)[:h, :w]
    d = (pixel_cell_d + rng.normal(0, 1.2, (h, w))).astype(np.float32)
    usable = rng.random((h, w)) < 0.8
    tol = np.maximum(1.0, 0.05 * np.abs(pixel_cell_d))
    expected = np.where(usable & (pixel_label >= 0) & (np.abs(d - pixel_cell_d) <= tol), pixel_label, -1)
    raw, counts = assign_pixels_kernel(d, usable, labels, cell_d, cell, 1.0, 0.05, 5)
    np.testing.assert_array_equal(raw, expected)
    np.testing.assert_array_equal(counts, [np.count_nonzero(expected == k) for k in range(5)])
    assert (expected == -1).any() and (expected >= 0).any()
