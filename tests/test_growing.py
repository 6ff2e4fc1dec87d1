"""The compiled growth and stable matching against the slow reference (tests/gcs_reference.py)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given
from hypothesis import strategies as st

import gcs_reference as ref
from stereo_obstacles.growing import QUEUE_BUCKETS, grow
from stereo_obstacles.seeds import Seeds, find_seeds, match_pixels
from stereo_obstacles.similarity import prepare_similarity, similarity_at
from stereo_obstacles.stable_matching import RowMatching, stable_matching


STEP = 0.5 / 32767 + 1e-6
"""Largest difference between a stored (quantised) similarity and the computed one."""


def _scene(seed=0, shape=(18, 34)):
    """Two fronto-parallel layers (disparity 3 behind, 6 in front) with noise: occlusions included."""
    rng = np.random.default_rng(seed)
    h, w = shape
    back = rng.uniform(0, 255, (h, w + 12))
    front = rng.uniform(0, 255, (h, w + 12))
    left = back[:, 0:w].copy()
    right = back[:, 3:w + 3].copy()
    left[:, 12:22] = front[:, 12:22]
    right[:, 6:16] = front[:, 12:22]
    left += rng.normal(0, 2, left.shape)
    right += rng.normal(0, 2, right.shape)
    return left.astype(np.float32), right.astype(np.float32)


@pytest.mark.parametrize("kind", ["ncc", "mncc"])
@pytest.mark.parametrize("greedy, use_max, k_max, buckets", [(False, True, 10, QUEUE_BUCKETS), (False, False, 3, 4096),
                                                             (True, True, 10, QUEUE_BUCKETS), (False, True, 10, 1)])
def test_growth_matches_reference(kind, greedy, use_max, k_max, buckets):
    left, right = _scene(seed=7)
    inputs = prepare_similarity(left, right, kind=kind)
    seeds = find_seeds(inputs, left, "random", d_min=0, d_max=9, tau=0.6, margin=0.1, random_fraction=0.02)
    assert len(seeds) > 0
    growth = grow(inputs, seeds, d_min=0, d_max=9, tau=0.6, mu=0.1, max_candidates=k_max,
                  margin_reference="max" if use_max else "min", greedy=greedy, queue_buckets=buckets)
    assert growth.n_overflow == 0
    order = np.argsort(-seeds.similarity, kind="stable")
    seed_list = [(int(seeds.y[i]), int(seeds.x[i]), int(seeds.x_right[i]), float(seeds.similarity[i]))
                 for i in order]
    expected = ref.grow(left, right, seed_list, d_min=0, d_max=9, tau=0.6, mu=0.1, k_max=k_max,
                        use_max=use_max, greedy=greedy, kind=kind, n_buckets=buckets)
    got = {(int(y), int(x), int(xr)): float(c)
           for y, x, xr, c in zip(growth.y, growth.x, growth.x_right, growth.similarity)}
    assert set(got) == set(expected)
    for q, c in expected.items():
        assert got[q] == pytest.approx(c, abs=2 * STEP)   # float32 window statistics may round one step apart
    if not greedy:
        won = stable_matching(growth.y, growth.x, growth.x_right, growth.similarity, left.shape, margin=0.1)
        winners = {(int(growth.y[i]), int(growth.x[i]), int(growth.x_right[i])) for i in np.flatnonzero(won)}
        assert winners == ref.stable_matching(got, margin=0.1)


def test_growth_matches_reference_beyond_the_memo_window():
    """Repetitive texture over a wide range: pixels hold points many disparities apart, so the
    memo's overflow blocks (codes outside a record's window) are used and must change nothing."""
    rng = np.random.default_rng(2)
    stripe = np.tile(rng.uniform(0, 255, 5), 12)            # period 5 px: every 5th disparity fits
    left = np.tile(stripe, (14, 1)) + rng.normal(0, 3, (14, 60))
    right = np.tile(stripe, (14, 1)) + rng.normal(0, 3, (14, 60))
    left, right = left.astype(np.float32), right.astype(np.float32)
    inputs = prepare_similarity(left, right)
    seeds = find_seeds(inputs, left, "random", d_min=0, d_max=24, tau=0.6, margin=0.0, random_fraction=0.05)
    growth = grow(inputs, seeds, d_min=0, d_max=24, tau=0.6, mu=0.3, max_candidates=6)
    assert growth.n_memo_blocks > 0 and growth.n_overflow == 0
    order = np.argsort(-seeds.similarity, kind="stable")
    seed_list = [(int(seeds.y[i]), int(seeds.x[i]), int(seeds.x_right[i]), float(seeds.similarity[i]))
                 for i in order]
    expected = ref.grow(left, right, seed_list, d_min=0, d_max=24, tau=0.6, mu=0.3, k_max=6)
    got = {(int(y), int(x), int(xr)): float(c)
           for y, x, xr, c in zip(growth.y, growth.x, growth.x_right, growth.similarity)}
    assert len(got) == growth.y.size and set(got) == set(expected)
    d = growth.x - growth.x_right
    assert np.ptp(d) >= 10                                   # matches of several periods
    inside = (d >= 1) & (d <= 23) & (growth.x_right >= 1) & (growth.x_right < left.shape[1] - 1)
    c_minus, c_plus = growth.side_similarities(growth.y[inside], growth.x[inside], d[inside])
    np.testing.assert_allclose(c_minus, similarity_at(inputs, growth.y[inside], growth.x[inside],
                                                      growth.x_right[inside] + 1), atol=STEP)
    np.testing.assert_allclose(c_plus, similarity_at(inputs, growth.y[inside], growth.x[inside],
                                                     growth.x_right[inside] - 1), atol=STEP)


def test_memo_cap_stores_no_more_points_and_keeps_the_table_right(monkeypatch):
    """With room for 2 points a pixel, further points are computed but not stored (counted), and
    never join the table: the table stays distinct correspondences with their true similarities."""
    import stereo_obstacles.growing as growing
    rng = np.random.default_rng(4)
    stripe = np.tile(rng.uniform(0, 255, 5), 12)
    left = (np.tile(stripe, (14, 1)) + rng.normal(0, 3, (14, 60))).astype(np.float32)
    right = (np.tile(stripe, (14, 1)) + rng.normal(0, 3, (14, 60))).astype(np.float32)
    inputs = prepare_similarity(left, right, kind="mncc")
    seeds = find_seeds(inputs, left, "random", d_min=2, d_max=26, tau=0.6, margin=0.0, random_fraction=0.05)
    monkeypatch.setattr(growing, "MEMO_SLOTS", 2)
    for greedy in (False, True):
        g = grow(inputs, seeds, d_min=2, d_max=26, tau=0.6, mu=0.3, max_candidates=6, greedy=greedy)
        assert g.n_overflow > 0 and g.y.size > 0
        keys = (g.y.astype(np.int64) * 100 + g.x) * 100 + g.x_right
        assert np.unique(keys).size == keys.size
        d = g.x - g.x_right
        assert d.min() >= 2 and d.max() <= 26
        np.testing.assert_allclose(g.similarity, similarity_at(inputs, g.y, g.x, g.x_right), atol=STEP)


def _layers_grown():
    """The two-layer scene (24 x 40) and its growth from Canny seeds."""
    left, right = _scene(seed=3, shape=(24, 40))
    inputs = prepare_similarity(left, right)
    seeds = find_seeds(inputs, left, "canny", d_min=0, d_max=9, tau=0.6, margin=0.1)
    return left, grow(inputs, seeds, d_min=0, d_max=9)


def test_growth_recovers_layers_and_leaves_occlusion():
    left, growth = _layers_grown()
    won = stable_matching(growth.y, growth.x, growth.x_right, growth.similarity, left.shape)
    d = np.full(left.shape, -1)
    d[growth.y[won], growth.x[won]] = growth.x[won] - growth.x_right[won]
    assert np.mean(d[:, 14:20] == 6) > 0.9       # front layer, away from its edges
    assert np.mean(d[:, 26:36] == 3) > 0.9       # background
    # left columns 9..11 see background hidden in the right image (occluded): mostly unmatched
    assert np.mean(d[2:-2, 9:11] == 3) < 0.5


def test_candidate_cap_limits_table_on_repetitive_texture():
    rng = np.random.default_rng(0)
    stripe = np.tile(rng.uniform(0, 255, 4), 20)            # period 4 px: every 4th disparity fits
    img = np.tile(stripe, (20, 1)).astype(np.float32) + rng.normal(0, 1, (20, 80)).astype(np.float32)
    inputs = prepare_similarity(img, img)
    seeds = Seeds(np.array([10], np.int32), np.array([40], np.int32), np.array([40], np.int32),
                  np.array([1.0], np.float32), 1, 1)
    for k in (1, 3):
        g = grow(inputs, seeds, d_min=0, d_max=30, max_candidates=k, mu=1.0)
        _, per_pixel = np.unique(g.y.astype(np.int64) * 1000 + g.x, return_counts=True)
        assert per_pixel.max() <= k


def test_memo_side_similarities_equal_direct_ones():
    left, right = _scene(seed=5)
    inputs = prepare_similarity(left, right)
    seeds = find_seeds(inputs, left, "canny", d_min=0, d_max=9, tau=0.6, margin=0.1)
    g = grow(inputs, seeds, d_min=0, d_max=9)
    d = g.x - g.x_right
    inside = (d >= 1) & (d <= 8) & (g.x_right >= 1) & (g.x_right < left.shape[1] - 1)
    c_minus, c_plus = g.side_similarities(g.y[inside], g.x[inside], d[inside])
    direct_minus = similarity_at(inputs, g.y[inside], g.x[inside], g.x_right[inside] + 1)
    direct_plus = similarity_at(inputs, g.y[inside], g.x[inside], g.x_right[inside] - 1)
    np.testing.assert_allclose(c_minus, direct_minus, atol=STEP)
    np.testing.assert_allclose(c_plus, direct_plus, atol=STEP)
    np.testing.assert_allclose(g.similarity, similarity_at(inputs, g.y, g.x, g.x_right), atol=STEP)


def test_stable_matching_uniqueness_and_errors():
    rng = np.random.default_rng(2)
    n = 400
    y = rng.integers(0, 5, n)
    x = rng.integers(0, 30, n)
    xr = rng.integers(0, 30, n)
    keys = np.unique(np.stack([y, x, xr], 1), axis=0)
    c = rng.uniform(0.6, 1.0, len(keys)).astype(np.float32)
    won = stable_matching(keys[:, 0], keys[:, 1], keys[:, 2], c, (5, 30), margin=0.05)
    w = keys[won]
    assert len(np.unique(w[:, [0, 1]], axis=0)) == len(w)
    assert len(np.unique(w[:, [0, 2]], axis=0)) == len(w)
    table = {tuple(int(v) for v in k): float(ci) for k, ci in zip(keys, c)}
    assert {tuple(int(v) for v in k) for k in w} == ref.stable_matching(table, margin=0.05)
    with pytest.raises(ValueError, match="inside"):
        stable_matching(np.array([9]), np.array([1]), np.array([1]), np.array([0.9]), (5, 30))


def test_row_ranges_matched_in_any_order_give_the_whole_matching():
    left, g = _layers_grown()
    whole = stable_matching(g.y, g.x, g.x_right, g.similarity, left.shape)
    assert whole.sum() > 0.5 * left.size
    for cuts in ([0, 24], [0, 7, 8, 24], [0, 1, 12, 13, 23, 24]):
        pieces = RowMatching(g.y, g.x, g.x_right, g.similarity, left.shape)
        for lo, hi in reversed(list(zip(cuts[:-1], cuts[1:]))):
            pieces.match_rows(lo, hi)
        np.testing.assert_array_equal(pieces.winner, whole)
    part = RowMatching(g.y, g.x, g.x_right, g.similarity, left.shape)
    part.match_rows(5, 9)
    in_rows = (g.y >= 5) & (g.y < 9)
    np.testing.assert_array_equal(part.winner, whole & in_rows)
    assert part.n_candidates(5, 9) == in_rows.sum() and part.n_candidates(0, 24) == g.y.size
    with pytest.raises(ValueError, match="lo, hi"):
        part.match_rows(9, 5)
    with pytest.raises(ValueError, match="lo, hi"):
        part.match_rows(0, 25)
    with pytest.raises(ValueError, match="lo, hi"):
        part.row_cuts(5, 2, 4)
    with pytest.raises(ValueError, match="n_pieces"):
        part.row_cuts(0, 24, 0)


@given(rows=st.lists(st.integers(0, 6), min_size=1, max_size=12), n_pieces=st.integers(1, 5),
       ends=st.tuples(st.integers(0, 12), st.integers(0, 12)))
@example(rows=[6, 6, 0, 0], n_pieces=2, ends=(0, 4))  # equal row counts would put all 12 in one piece
def test_row_cuts_split_rows_into_pieces_of_about_equal_candidate_counts(rows, n_pieces, ends):
    ys = np.repeat(np.arange(len(rows)), rows)  # rows[r] candidates on row r, at distinct columns
    xs = np.concatenate([np.arange(n) for n in rows]).astype(np.int64)
    matching = RowMatching(ys, xs, xs, np.full(ys.size, 0.9), (len(rows), 8))
    lo, hi = sorted(min(e, len(rows)) for e in ends)
    cuts = matching.row_cuts(lo, hi, n_pieces)
    assert len(cuts) == n_pieces + 1 and cuts[0] == lo and cuts[-1] == hi
    assert all(a <= b for a, b in zip(cuts[:-1], cuts[1:]))
    share = matching.n_candidates(lo, hi) / n_pieces
    largest_row = max(rows[lo:hi], default=0)
    for a, b in zip(cuts[:-1], cuts[1:]):  # a piece exceeds its share by less than one row
        n = matching.n_candidates(a, b)
        assert n == 0 or n < share + largest_row


def test_points_of_seed_scanlines_are_not_counted_twice():
    left, right = _scene(seed=4)
    h, w = left.shape
    inputs = prepare_similarity(left, right)
    ys, xs = np.nonzero(np.ones((h, w), bool))
    seeds = match_pixels(inputs, ys.astype(np.int32), xs.astype(np.int32), d_min=0, d_max=9, tau=0.6, margin=0.1)
    g = grow(inputs, seeds, d_min=0, d_max=9, scanned_hi=seeds.scanned_hi)
    assert g.n_computed > 0
    assert g.n_rescanned == g.n_computed          # every pixel's whole range was scanned already
    plain = grow(inputs, seeds, d_min=0, d_max=9)
    assert plain.n_rescanned == 0 and plain.n_computed == g.n_computed


def test_with_negative_disparities_unscanned_pixels_count_no_rescanned_points():
    left, right = _scene(seed=4)
    inputs = prepare_similarity(left, right)
    seeds = match_pixels(inputs, np.array([9], np.int32), np.array([30], np.int32), d_min=-3, d_max=9, tau=0.6,
                         margin=0.1)
    assert seeds.scanned_hi[9, 30] == 9 and seeds.scanned_hi[9, 29] < -3
    g = grow(inputs, seeds, d_min=-3, d_max=9, scanned_hi=seeds.scanned_hi)
    assert 0 < g.n_rescanned <= 13 < g.n_computed          # only the seed pixel's range was scanned
    assert grow(inputs, seeds, d_min=-3, d_max=9).n_rescanned == 0


@pytest.mark.parametrize("values", [
    np.random.default_rng(8).uniform(0.6, 1.0, 500),
    np.round(np.random.default_rng(9).uniform(0.6, 1.0, 300), 2),   # many ties
    np.full(7, 0.9), np.array([0.7]), np.array([]),
])
def test_best_first_order_is_a_stable_descending_sort(values):
    from stereo_obstacles._stable_matching_kernel import _best_first
    c = values.astype(np.float32)
    np.testing.assert_array_equal(_best_first(c), np.argsort(-c, kind="stable"))


def test_a_seed_similarity_above_one_counts_as_one_not_as_a_wrapped_negative():
    """Seeds may come from outside (the previous frame's matches); a similarity rounded a little
    above 1 must not wrap round in the int16 store and drop the seed below ``tau``."""
    left, right = _scene(seed=3, shape=(24, 40))
    inputs = prepare_similarity(left, right)
    one_seed = [np.array([12]), np.array([30]), np.array([27])]       # background, disparity 3
    grown = {c: grow(inputs, Seeds(*one_seed, np.array([c], np.float32), 0, 1), d_min=0, d_max=9).y.size
             for c in (1.0, 1.0 + 1e-4, 1.5)}
    assert grown[1.0] > 50 and grown[1.0 + 1e-4] == grown[1.0] == grown[1.5]
