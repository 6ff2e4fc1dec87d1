"""Joining neighbouring groups that lie on one plane in disparity."""

from __future__ import annotations

import numpy as np
import pytest

from stereo_obstacles._coplanar_merging_kernel import group_sums_kernel
from stereo_obstacles.coplanar_merging import merge_coplanar_groups
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.obstacle_grouping import GroupingParameters

TOLERANCES = dict(cell_px=8, tolerance_px=0.15, rel_tolerance=0.01)
"""The tests' own tolerances (the grouping's default until session 46; it joins at 0.12 px now)."""


@pytest.mark.parametrize("seed, reach", [(0, 1), (1, 1), (2, 1), (3, 2), (4, 3)])
def test_group_sums_and_neighbour_pairs_agree_with_numpy(seed, reach):
    rng = np.random.default_rng(seed)
    h, w, cell, n = 45, 61, 8, 6                                      # partial cells at the borders
    groups = np.full((h, w), -1, np.int64)
    for g in range(n):                                                # blobs: some touch, some do not
        y, x = rng.integers(0, h - 6), rng.integers(0, w - 6)
        groups[y:y + rng.integers(2, 7), x:x + rng.integers(2, 7)] = g
    disparity = rng.uniform(1, 60, (h, w)).astype(np.float32)
    sums, keys, farther = group_sums_kernel(groups, disparity, cell, n, reach)
    cells = np.zeros((n, 6, 8), bool)
    for g in range(n):
        ys, xs = np.nonzero(groups == g)
        x, y, d = xs.astype(float), ys.astype(float), disparity[ys, xs].astype(float)
        expected = [x.size, x.sum(), y.sum(), d.sum(), (x * x).sum(), (x * y).sum(), (y * y).sum(),
                    (x * d).sum(), (y * d).sum(), (d * d).sum()]
        np.testing.assert_allclose(sums[g], expected, rtol=1e-12)
        cells[g, ys // cell, xs // cell] = True

    def apart(g, k):
        """The Chebyshev distances (in cells) between a cell of g and a cell of k."""
        gy, gx = np.nonzero(cells[g])
        ky, kx = np.nonzero(cells[k])
        return np.maximum(np.abs(gy[:, None] - ky[None, :]), np.abs(gx[:, None] - kx[None, :]))

    pairs = [(g, k) for g in range(n) for k in range(g + 1, n)]
    expected_keys = [g * n + k for g, k in pairs if apart(g, k).min() <= 1]
    np.testing.assert_array_equal(keys, expected_keys)
    assert 0 < len(expected_keys) < len(pairs)
    expected_farther = [g * n + k for g, k in pairs if ((apart(g, k) > 1) & (apart(g, k) <= reach)).any()]
    np.testing.assert_array_equal(farther, expected_farther)
    assert (len(expected_farther) > 0) == (reach > 1)


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


def test_noisy_pieces_of_a_wall_are_joined_by_their_own_planes_not_by_their_noise():
    """With 0.4 px of noise each piece lies 0.4 px (rms) off any plane, its own included: the test
    compares the joint plane with the piece's own one, not with its pixels."""
    groups, d = _plane_pieces(slice(60, 66))
    d += np.random.default_rng(1).normal(0, 0.4, d.shape).astype(np.float32)
    assert merge_coplanar_groups(groups, d, **TOLERANCES).max() == 0


def test_the_tolerance_grows_with_the_disparity():
    """Two pieces of a near surface curved a little (0.0002 px per px squared): the joint plane lies
    0.29 px off each piece's own; within 0.15 px + 1 % of 30 px, not within 0.15 px."""
    groups, _ = _plane_pieces(slice(60, 66))
    x = np.arange(160, dtype=np.float32) - 80.0
    d = np.where(groups >= 0, 30.0 + 0.0002 * x[None, :] ** 2, np.nan).astype(np.float32)
    assert merge_coplanar_groups(groups, d, **TOLERANCES).max() == 0
    assert merge_coplanar_groups(groups, d, **dict(TOLERANCES, rel_tolerance=0.0)).max() == 1


def test_pieces_more_than_one_cell_apart_stay_apart():
    groups, d = _plane_pieces(slice(64, 72))                          # cell 8 empty between cells 7 and 9
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


def test_a_box_and_a_pole_beside_it_stay_apart_at_the_default_tolerance():
    """Scene 1356's kind: a box (7.25 px of disparity) and a pole 0.75 px farther, 2 px beside it
    (neighbouring cells). The plane slanted in x through both lies 0.208 px (rms) off the box's own
    flat plane: beyond the grouping's default 0.12 px + 1 % of d (0.19 px), within the 0.15 px + 1 %
    used until session 46 (0.22 px), which joined them."""
    d = np.full((128, 96), np.nan, np.float32)
    groups = np.full(d.shape, -1, np.int64)
    groups[64:112, 16:48], d[64:112, 16:48] = 0, 7.25       # the box
    groups[0:112, 50:66], d[0:112, 50:66] = 1, 6.5          # the pole
    defaults = GroupingParameters()
    tolerances = dict(cell_px=defaults.cell_px, tolerance_px=defaults.coplanar_tolerance_px,
                      rel_tolerance=defaults.coplanar_rel_tolerance)
    np.testing.assert_array_equal(merge_coplanar_groups(groups, d, **tolerances), groups)
    assert merge_coplanar_groups(groups, d, **dict(tolerances, tolerance_px=0.15)).max() == 0


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


def test_a_piece_that_pins_no_plane_down_is_not_joined():
    """One row of a slanted wall beside a flat block: the row fits its own line exactly but any
    plane through both lies far off it."""
    d = np.full((64, 64), np.nan, np.float32)
    groups = np.full(d.shape, -1, np.int64)
    d[20, 8:40], groups[20, 8:40] = 8.0 + 0.05 * np.arange(32), 0
    d[21:40, 8:40], groups[21:40, 8:40] = 8.5, 1
    np.testing.assert_array_equal(merge_coplanar_groups(groups, d, **TOLERANCES), groups)


def test_bad_labels_are_refused():
    groups, d = _plane_pieces(slice(60, 66))
    with pytest.raises(InvalidInputError, match="split_from"):
        merge_coplanar_groups(groups, d, **TOLERANCES, split_from=np.array([0]))
    groups[0, 0] = -2
    with pytest.raises(InvalidInputError, match="labels must be -1"):
        merge_coplanar_groups(groups, d, **TOLERANCES)


def test_nothing_to_join_is_returned_as_given():
    groups = np.full((16, 16), -1, np.int64)
    d = np.full((16, 16), np.nan, np.float32)
    assert merge_coplanar_groups(groups, d, **TOLERANCES) is groups
    groups[2:10, 2:10], d[2:10, 2:10] = 0, 5.0
    assert merge_coplanar_groups(groups, d, **TOLERANCES) is groups


def _alike(first, second):
    """Mean chroma ``(a*, b*)`` of the two pieces of :func:`_plane_pieces`."""
    return np.array([first, second], dtype=np.float64)


def test_pieces_of_one_colour_two_cells_apart_are_joined():
    """Cell 8 empty between cells 7 and 9: with the pieces' colours, one colour, they are tested
    and joined; of two colours, or without colours, not."""
    groups, d = _plane_pieces(slice(64, 72))
    reach = dict(TOLERANCES, colour_reach_cells=2, max_chroma_distance=5.0)
    joined = merge_coplanar_groups(groups, d, **reach, colours=_alike((150, 150), (152, 147)))
    np.testing.assert_array_equal(joined, np.where(groups >= 0, 0, -1))
    np.testing.assert_array_equal(merge_coplanar_groups(groups, d, **reach, colours=_alike((150, 150), (128, 100))),
                                  groups)
    np.testing.assert_array_equal(merge_coplanar_groups(groups, d, **reach), groups)
    np.testing.assert_array_equal(merge_coplanar_groups(groups, d, **dict(reach, colour_reach_cells=1),
                                                        colours=_alike((150, 150), (150, 150))), groups)


def test_pieces_of_one_colour_farther_than_the_reach_stay_apart():
    groups, d = _plane_pieces(slice(64, 80))                          # cells 8 and 9 empty
    reach = dict(TOLERANCES, colour_reach_cells=2, max_chroma_distance=5.0)
    np.testing.assert_array_equal(merge_coplanar_groups(groups, d, **reach, colours=_alike((150, 150), (150, 150))),
                                  groups)
    assert merge_coplanar_groups(groups, d, **dict(reach, colour_reach_cells=3),
                                 colours=_alike((150, 150), (150, 150))).max() == 0


def test_a_joined_group_is_compared_by_its_mean_colour():
    """Piece 1 joins piece 0 (neighbouring cells, any colour); piece 2, two cells from piece 1,
    has piece 0's colour but not the mean colour of pieces 0 and 1 together (by pixel count)."""
    d = np.full((96, 200), np.nan, np.float32)
    d[16:80, 8:184] = 8.0 + 0.05 * np.arange(8, 184, dtype=np.float32)
    groups = np.full(d.shape, -1, np.int64)
    groups[16:80, 8:60], groups[16:80, 60:120], groups[16:80, 128:184] = 0, 1, 2      # cell 15 empty
    d[groups < 0] = np.nan
    reach = dict(TOLERANCES, colour_reach_cells=2, max_chroma_distance=5.0)
    colours = np.array([(150.0, 150.0), (130.0, 130.0), (150.0, 150.0)])
    joined = merge_coplanar_groups(groups, d, **reach, colours=colours)
    assert joined[20, 10] == joined[20, 100] != joined[20, 150]
    colours[1] = (151.0, 151.0)
    assert merge_coplanar_groups(groups, d, **reach, colours=colours).max() == 0


def test_colours_of_another_shape_are_refused():
    groups, d = _plane_pieces(slice(64, 72))
    with pytest.raises(InvalidInputError, match="colours"):
        merge_coplanar_groups(groups, d, **TOLERANCES, colours=np.zeros((3, 2)))
