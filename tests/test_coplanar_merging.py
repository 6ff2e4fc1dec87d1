"""Joining neighbouring groups that lie on one plane in disparity and meet without a step."""

from __future__ import annotations

import numpy as np
import pytest

from stereo_obstacles._coplanar_merging_kernel import group_sums_kernel
from stereo_obstacles.coplanar_merging import merge_coplanar_groups

TOLERANCES = dict(cell_px=8, tolerance_px=0.15, rel_tolerance=0.01)


@pytest.mark.parametrize("seed", range(3))
def test_group_sums_and_cells_agree_with_numpy(seed):
    rng = np.random.default_rng(seed)
    h, w, cell, n = 45, 61, 8, 4                                      # partial cells at the borders
    groups = np.where(rng.random((h, w)) < 0.9, rng.integers(-1, n, (h, w)), -1)
    groups[:, :20][groups[:, :20] == 3] = -1                          # group 3 occupies only some cells
    disparity = rng.uniform(1, 60, (h, w)).astype(np.float32)
    sums, occupied = group_sums_kernel(groups, disparity, cell, n)
    for g in range(n):
        ys, xs = np.nonzero(groups == g)
        x, y, d = xs.astype(float), ys.astype(float), disparity[ys, xs].astype(float)
        expected = [x.size, x.sum(), y.sum(), d.sum(), (x * x).sum(), (x * y).sum(), (y * y).sum(),
                    (x * d).sum(), (y * d).sum(), (d * d).sum()]
        np.testing.assert_allclose(sums[g], expected, rtol=1e-12)
        expected_cells = np.zeros((6, 8), bool)
        expected_cells[ys // cell, xs // cell] = True
        np.testing.assert_array_equal(occupied[g], expected_cells)
    assert not occupied[3].all() and occupied[3].any()


def _plane_pieces(gap_columns: slice, slope: float = 0.05):
    """A wall slanted in x (disparity 8 + slope * x px) in rows 16..79, columns 8..151, cut into
    two groups by unmatched ``gap_columns``."""
    d = np.full((96, 160), np.nan, np.float32)
    x = np.arange(160, dtype=np.float32)
    d[16:80, 8:152] = 8.0 + slope * x[8:152]
    d[:, gap_columns] = np.nan
    groups = np.full(d.shape, -1, np.int64)
    groups[16:80, 8:gap_columns.start] = 0
    groups[16:80, gap_columns.stop:152] = 1
    return groups, d


def test_pieces_of_one_slanted_wall_are_joined():
    groups, d = _plane_pieces(slice(60, 66))                          # cells 7 and 8 touch across the gap
    rng = np.random.default_rng(0)
    d += rng.normal(0, 0.1, d.shape).astype(np.float32)
    joined = merge_coplanar_groups(groups, d, **TOLERANCES)
    np.testing.assert_array_equal(joined, np.where(groups >= 0, 0, -1))


def test_pieces_more_than_one_cell_apart_stay_apart():
    groups, d = _plane_pieces(slice(60, 80))                          # an empty cell column between them
    np.testing.assert_array_equal(merge_coplanar_groups(groups, d, **TOLERANCES), groups)


def test_objects_side_by_side_at_different_depths_stay_apart():
    """Two upright faces side by side, 1.5 px apart: a plane slanted in x passes through both on
    average, but it is neither's own (flat) plane."""
    d = np.full((96, 160), np.nan, np.float32)
    d[16:80, 40:64], d[16:80, 64:88] = 7.4, 8.9
    groups = np.full(d.shape, -1, np.int64)
    groups[16:80, 40:64], groups[16:80, 64:88] = 0, 1
    np.testing.assert_array_equal(merge_coplanar_groups(groups, d, **TOLERANCES), groups)
    assert merge_coplanar_groups(groups, d, **dict(TOLERANCES, tolerance_px=0.5)).max() == 0    # 0.43 px off


def test_a_pole_rising_behind_a_box_stays_apart():
    """A pole (7.4 px) above and behind a box (8.2 px) in the same columns: a plane slanted in y
    meets both where they touch, but it is not the pole's own (upright) plane."""
    d = np.full((160, 96), np.nan, np.float32)
    d[0:120, 40:56] = 7.4
    d[104:144, 24:72] = 8.2
    groups = np.full(d.shape, -1, np.int64)
    groups[0:104, 40:56] = 0
    groups[104:144, 24:72] = 1
    d[groups < 0] = np.nan
    np.testing.assert_array_equal(merge_coplanar_groups(groups, d, **TOLERANCES), groups)
    assert merge_coplanar_groups(groups, d, **dict(TOLERANCES, tolerance_px=5.0)).max() == 0


def test_a_chain_of_pieces_is_joined_and_labels_stay_compact():
    groups, d = _plane_pieces(slice(60, 66))
    groups[16:80, 100:152] = 2                                        # the right piece cut once more...
    d[:, 96:100] = np.nan
    groups[:, 96:100] = -1                                            # ...by a gap within one cell
    far = (slice(88, 96), slice(0, 40))
    d[far], groups[far] = 30.0, 3                                     # and an unrelated group
    joined = merge_coplanar_groups(groups, d, **TOLERANCES)
    np.testing.assert_array_equal(joined[groups >= 0], np.where(groups[groups >= 0] == 3, 1, 0))
    assert np.all(joined[groups < 0] == -1)


def test_layers_split_apart_are_not_joined_again_directly_or_through_another_piece():
    groups, d = _plane_pieces(slice(60, 66))
    groups[16:80, 100:152] = 2
    d[:, 96:100] = np.nan
    groups[:, 96:100] = -1                                            # three pieces of one plane: 0, 1, 2
    assert merge_coplanar_groups(groups, d, **TOLERANCES).max() == 0
    kept_apart = merge_coplanar_groups(groups, d, **TOLERANCES, split_from=np.array([5, 7, 5]))
    assert kept_apart[30, 20] != kept_apart[30, 120]                  # 0 and 2 came from one group
    assert kept_apart[30, 80] in (kept_apart[30, 20], kept_apart[30, 120])   # 1 joins one of them


def test_nothing_to_join_is_returned_as_given():
    groups = np.full((16, 16), -1, np.int64)
    d = np.full((16, 16), np.nan, np.float32)
    assert merge_coplanar_groups(groups, d, **TOLERANCES) is groups
    groups[2:10, 2:10], d[2:10, 2:10] = 0, 5.0
    assert merge_coplanar_groups(groups, d, **TOLERANCES) is groups
