"""Shifted-window check: the compiled kernel against a slow NumPy reference, and its effect."""

from __future__ import annotations

import numpy as np
import pytest

from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.matching import match
from stereo_obstacles.shifted_windows import ShiftedWindowCheck, shifted_window_check, shifted_window_check_map
from stereo_obstacles.similarity import prepare_similarity, similarity_at


def _fattening_scene(shape=(40, 80), seed=5):
    """Weak background texture at disparity 3, a strongly textured square at disparity 10."""
    rng = np.random.default_rng(seed)
    h, w = shape
    back = 100 + rng.normal(0, 6, (h, w + 20))
    front = rng.uniform(0, 255, (h, w + 20))
    left, right = back[:, 0:w].copy(), back[:, 3:w + 3].copy()
    left[10:30, 35:60] = front[10:30, 35:60]
    right[10:30, 25:50] = front[10:30, 35:60]
    truth = np.full(shape, 3.0)
    truth[10:30, 35:60] = 10.0
    return left.astype(np.float32), right.astype(np.float32), truth


def _reference(inputs, ys, xs, ds):
    """Per match: alternatives are the distinct disparities of matches in its 5x5 square more than
    1 px away; best over the nine windows centred on the pixel and 2 px away from it in each
    direction; rejected if an alternative beats d."""
    h, w = inputs.shape
    d_map = np.full((h + 4, w + 4), -100)
    d_map[ys + 2, xs + 2] = ds

    def best(y, x, d):
        values = [similarity_at(inputs, yc, xc, xc - d)[()] for yc in (y - 2, y, y + 2) for xc in (x - 2, x, x + 2)
                  if 0 <= yc < h and 0 <= xc < w and 0 <= xc - d < w]
        return max(values, default=-1.0)

    keep, n_checked = [], 0
    for y, x, d in zip(ys, xs, ds):
        square = d_map[y:y + 5, x:x + 5]
        alts = {int(a) for a in square[(square >= 0) & (np.abs(square - d) > 1)]}
        if alts:
            n_checked += 1
        own = best(y, x, d) if alts else None
        keep.append(all(best(y, x, a) <= own for a in alts))
    return np.array(keep), n_checked


def _unchecked_matches():
    """The fattening scene's prepared images and its matches without the check: rows, columns,
    integer disparities."""
    left, right, _ = _fattening_scene()
    result = match(left, right, max_disparity=14, shifted_windows=False)
    ys, xs = np.nonzero(np.isfinite(result.disparity))
    return prepare_similarity(left, right), ys, xs, np.rint(result.disparity[ys, xs]).astype(int)


def test_kernel_agrees_with_reference():
    inputs, ys, xs, ds = _unchecked_matches()
    keep, n_checked = shifted_window_check(inputs, ys, xs, ds)
    expected, expected_checked = _reference(inputs, ys, xs, ds)
    assert n_checked == expected_checked > 0
    np.testing.assert_array_equal(keep, expected)
    assert not keep.all()
    for n_threads in (2, 3):  # chunks in threads give the same answer
        keep_t, checked_t = shifted_window_check(inputs, ys, xs, ds, n_threads=n_threads)
        np.testing.assert_array_equal(keep_t, expected)
        assert checked_t == expected_checked


def test_map_of_matches_gives_the_verdicts_of_the_list():
    inputs, ys, xs, ds = _unchecked_matches()
    expected, expected_checked = _reference(inputs, ys, xs, ds)
    d_map = np.full(inputs.shape, -1, np.int32)
    d_map[ys, xs] = ds
    for n_threads in (1, 2):
        rejected, n_checked = shifted_window_check_map(inputs, d_map, n_threads=n_threads)
        assert n_checked == expected_checked
        np.testing.assert_array_equal(rejected[ys, xs], ~expected)
        assert np.count_nonzero(rejected) == np.count_nonzero(~expected) > 0   # nothing rejected off the matches


def test_map_of_matches_is_validated():
    inputs = prepare_similarity(*_fattening_scene()[:2])
    d_map = np.full(inputs.shape, -1, np.int32)
    d_map[3, 2] = 5                                               # right pixel left of the image
    with pytest.raises(InvalidInputError, match="inside"):
        shifted_window_check_map(inputs, d_map)
    d_map[3, 2] = -2                                  # negative: unmatched (or a negative disparity, not checked)
    rejected, n_checked = shifted_window_check_map(inputs, d_map)
    assert not rejected.any() and n_checked == 0
    with pytest.raises(InvalidInputError, match="int32 of shape"):
        shifted_window_check_map(inputs, np.full(inputs.shape, -1, np.int64))
    with pytest.raises(InvalidInputError, match="int32 of shape"):
        shifted_window_check_map(inputs, np.full((4, 4), -1, np.int32))
    check = ShiftedWindowCheck(inputs)
    check.add(np.array([3]), np.array([9]), np.array([1]))
    d_map[3, 2] = -1
    d_map[3, 9] = 1
    with pytest.raises(InvalidInputError, match="each left pixel at most once"):
        check.add_map(d_map)


def test_check_removes_fattened_pixels():
    left, right, truth = _fattening_scene()
    plain = match(left, right, max_disparity=14, shifted_windows=False)
    checked = match(left, right, max_disparity=14, shifted_windows=True)

    def n_bad(result):
        m = np.isfinite(result.disparity)
        return int(np.count_nonzero(np.abs(result.disparity[m] - truth[m]) > 1))

    assert n_bad(plain) > 0
    assert n_bad(checked) < n_bad(plain)
    assert checked.stats.n_edge_rejected > 0 and checked.stats.n_edge_checked >= checked.stats.n_edge_rejected
    assert plain.stats.n_edge_checked == 0
    assert checked.stats.density > plain.stats.density - 0.05


def test_validation():
    inputs = prepare_similarity(*(np.random.default_rng(0).uniform(0, 255, (2, 12, 20)).astype(np.float32)))
    with pytest.raises(InvalidInputError, match="inside"):
        shifted_window_check(inputs, np.array([3]), np.array([2]), np.array([5]))
    for y, x, d in ((-1, 5, 1), (12, 5, 1), (3, 20, 1), (3, 5, -1)):  # row, column, disparity outside
        with pytest.raises(InvalidInputError, match="inside"):
            shifted_window_check(inputs, np.array([1, y]), np.array([9, x]), np.array([1, d]))
    with pytest.raises(InvalidInputError, match="at most once"):
        shifted_window_check(inputs, np.array([3, 3]), np.array([9, 9]), np.array([1, 2]))
    with pytest.raises(InvalidInputError, match="one length"):
        shifted_window_check(inputs, np.array([3, 4]), np.array([9]), np.array([1]))
    with pytest.raises(InvalidInputError, match="n_threads"):
        shifted_window_check(inputs, np.array([3]), np.array([9]), np.array([1]), n_threads=0)


def test_disparity_command_options(tmp_path, capsys):
    import json

    from stereo_obstacles.cli import main
    from stereo_obstacles.fileio import read_disparity, write_image

    left, right, truth = _fattening_scene()
    write_image(tmp_path / "l.png", np.clip(left, 0, 255).astype(np.uint8))
    write_image(tmp_path / "r.png", np.clip(right, 0, 255).astype(np.uint8))
    out = tmp_path / "d.npy"
    assert main(["disparity", str(tmp_path / "l.png"), str(tmp_path / "r.png"), "-o", str(out),
                 "--max-disparity", "14", "--bands", "2", "--shifted-windows", "--json"]) == 0
    stats = json.loads(capsys.readouterr().out.strip())
    assert stats["n_edge_checked"] > 0 and stats["edge_check_seconds"] > 0
    d = read_disparity(out)
    m = np.isfinite(d)
    assert m.mean() > 0.5 and np.mean(np.abs(d[m] - truth[m]) <= 1) > 0.9


def test_strips_of_rows_give_the_verdicts_of_the_whole_image():
    inputs, ys, xs, ds = _unchecked_matches()
    expected, expected_checked = _reference(inputs, ys, xs, ds)
    h = inputs.shape[0]
    for cuts in ([0, h], [0, 11, 12, 29, h], [0, 1, 2, 3, 20, 21, h]):
        check = ShiftedWindowCheck(inputs)
        top = ys < 20  # matches added in two parts, as two bands add theirs, the second from a table
        check.add(ys[top], xs[top], ds[top])
        band = np.flatnonzero(~top)  # band rows start at image row 15, one extra candidate per match
        table_y = np.concatenate([ys[band], ys[band]]) - 15
        table_x = np.concatenate([xs[band], xs[band]])
        table_xr = np.concatenate([xs[band] - ds[band], xs[band]])
        check.add_from_table(table_y, table_x, table_xr, np.arange(band.size)[::-1], row_offset=15)
        n_checked = sum(check.check_rows(lo, hi) for lo, hi in reversed(list(zip(cuts[:-1], cuts[1:]))))
        np.testing.assert_array_equal(check.keep(ys, xs), expected)
        assert n_checked == expected_checked


def test_strip_check_refuses_bad_rows_and_repeated_pixels():
    inputs = prepare_similarity(*_fattening_scene()[:2])
    check = ShiftedWindowCheck(inputs)
    check.add(np.array([3]), np.array([9]), np.array([1]))
    with pytest.raises(InvalidInputError, match="each left pixel at most once"):
        check.add(np.array([3]), np.array([9]), np.array([2]))
    table = np.array([4, 5]), np.array([9, 9]), np.array([8, 10])  # the second has x_right > x
    with pytest.raises(InvalidInputError, match=r"index: expected entries in \[0, 2\)"):
        check.add_from_table(*table, np.array([0, 2]))
    with pytest.raises(InvalidInputError, match="inside"):
        check.add_from_table(*table, np.array([0, 1]))
    with pytest.raises(InvalidInputError, match="signed integer"):  # unsigned columns would wrap around
        check.add_from_table(*(a.astype(np.uint32) for a in table), np.array([1]))
    with pytest.raises(InvalidInputError, match="signed integer"):
        check.add_from_table(*table, np.array([0.0]))
    with pytest.raises(InvalidInputError, match="lo, hi"):
        check.count_jumps(0, 41)
    with pytest.raises(InvalidInputError, match="lo, hi"):
        check.check_rows(5, 41)
    with pytest.raises(InvalidInputError, match="lo, hi"):
        check.check_rows(6, 5)
    assert check.check_rows(7, 7) == 0
    assert check.keep(np.array([3, 39]), np.array([9, 79])).tolist() == [True, True]
    with pytest.raises(InvalidInputError, match="inside the 80x40 image"):
        check.keep(np.array([0]), np.array([80]))  # not the first pixel of row 1


def test_jumps_near_counts_neighbouring_matches_apart_by_more_than_one_pixel():
    inputs = prepare_similarity(*_fattening_scene()[:2])
    check = ShiftedWindowCheck(inputs)
    # row 10: disparities 3, 5 (a jump), 6 (none), unmatched, 9 (none: no neighbour); row 20: 2, 4
    check.add(np.array([10, 10, 10, 10, 20, 20]), np.array([14, 15, 16, 18, 14, 15]), np.array([3, 5, 6, 9, 2, 4]))
    check.count_jumps(0, 15)
    assert check.jumps_near(10, 11) == 1 and check.jumps_near(13, 14) == 0  # row 10 lies within RADIUS of 12
    assert check.jumps_near(19, 21) == 0  # rows 15 and on not counted yet
    check.count_jumps(15, inputs.shape[0])
    assert check.jumps_near(0, inputs.shape[0]) == 2 and check.jumps_near(22, 23) == 1
