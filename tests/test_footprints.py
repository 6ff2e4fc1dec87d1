"""Footprints on the ground plan: one point (or span of depths) per image column, and their close
points (or spans)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.footprints import BLOCK_POINTS, close_points, close_spans, footprint, footprint_spans

RIG = StereoCalibration(focal_px=350.0, cx_px=160.0, cy_px=120.0, baseline_m=0.12)   # f B = 42 px m


def test_footprint_points_are_column_medians_in_metres():
    xs = np.repeat(np.arange(150, 162), 4)                  # 12 columns of 4 pixels at 4.2 m
    d = np.full(xs.shape, 10.0)
    d[1] = np.nan                                           # column 150 keeps 3 matches
    xs, d = np.append(xs, [170, 170]), np.append(d, [10.0, 10.0])     # column 170: 2 matches, left out
    points = footprint(xs, d, RIG)
    np.testing.assert_allclose(points[:, 1], 4.2)
    np.testing.assert_allclose(points[:, 0], (np.arange(154, 158) - 160) * 4.2 / 350)   # 4 edge columns trimmed
    assert footprint(xs[:20], d[:20], RIG).shape == (5, 2)  # 5 columns, too few to trim
    assert footprint(xs, np.full(xs.shape, np.nan), RIG).shape == (0, 2)


def test_a_footprint_leaves_out_columns_at_or_behind_infinity():
    xs = np.repeat(np.arange(10), 3)
    d = np.where(xs < 5, 10.0, 0.0)                         # doffs 0: d + doffs = 0 has no depth
    assert len(footprint(xs, d, RIG, edge_columns=0)) == 5
    assert len(footprint(xs, d, replace(RIG, doffs_px=2.0), edge_columns=0)) == 10


def _random_pixels(seed):
    """600 pixels in columns 100-139 with random disparities (a fifth unmatched), and random
    ``edge_columns`` and ``min_column_pixels``."""
    rng = np.random.default_rng(seed)
    d = rng.uniform(4.0, 30.0, 600)
    d[rng.random(600) < 0.2] = np.nan
    return rng.integers(100, 140, 600), d, int(rng.integers(0, 4)), int(rng.integers(1, 6)), rng


def _column_by_column(xs, d, edge_columns, min_column_pixels, statistics):
    """``(column, statistic of its matched disparities, ...)`` for each column a footprint keeps,
    computed one column at a time."""
    kept = []
    for x in np.unique(xs):
        column = d[(xs == x) & np.isfinite(d)]
        if len(column) >= min_column_pixels:
            kept.append((x, *(statistic(column) for statistic in statistics)))
    columns = np.array([k[0] for k in kept])
    if len(columns) >= 2 * edge_columns + 2:
        kept = [k for k in kept if columns.min() + edge_columns <= k[0] <= columns.max() - edge_columns]
    return kept


@pytest.mark.parametrize("seed", range(20))
def test_footprint_points_match_a_column_by_column_reference(seed):
    xs, d, edge_columns, min_column_pixels, _ = _random_pixels(seed)
    kept = _column_by_column(xs, d, edge_columns, min_column_pixels, (np.median,))
    expected = np.array([((x - RIG.cx_px) * (RIG.focal_baseline_px_m / m) / RIG.focal_px,
                          RIG.focal_baseline_px_m / m) for x, m in kept])
    np.testing.assert_allclose(footprint(xs, d, RIG, edge_columns=edge_columns, min_column_pixels=min_column_pixels),
                               expected, rtol=1e-12)


def test_a_footprint_refuses_columns_that_are_not_integers_or_arrays_of_two_lengths():
    with pytest.raises(InvalidInputError, match="1-D arrays of one length"):
        footprint(np.arange(5), np.ones(4), RIG)
    with pytest.raises(InvalidInputError, match="integer columns"):
        footprint(np.arange(5.0), np.ones(5), RIG)
    with pytest.raises(InvalidInputError, match="xs must be image columns at most 1048576 apart and below 2"):
        footprint(np.array([0, (1 << 20) + 1]), np.ones(2), RIG)
    with pytest.raises(InvalidInputError, match="got 9223372036854775808 to 9223372036854775809"):
        footprint(np.array([1 << 63, (1 << 63) + 1], dtype=np.uint64), np.ones(2), RIG)
    assert footprint(np.repeat([0, 1 << 20], 3), np.ones(6), RIG).shape == (2, 2)     # the widest span taken
    # an unmatched pixel far out does not count: only matched pixels need a table of columns
    assert len(footprint(np.array([0, 0, 0, 1 << 40]), np.array([10.0, 10.0, 10.0, np.nan]), RIG)) == 1


def test_bucket_medians_count_and_take_the_median_of_each_bucket():
    from stereo_obstacles._obstacles_kernel import bucket_medians_kernel

    rng = np.random.default_rng(7)
    keys = rng.integers(0, 9, 200) * 2                      # buckets 0, 2, ..., 16: the odd ones and 18 empty
    values = rng.uniform(-5.0, 5.0, 200)
    counts, medians = bucket_medians_kernel(keys, values, 20)
    np.testing.assert_array_equal(counts, np.bincount(keys, minlength=20))
    for bucket in range(20):
        if counts[bucket]:
            assert medians[bucket] == np.median(values[keys == bucket])
        else:
            assert np.isnan(medians[bucket])


def test_a_footprint_takes_columns_of_any_integer_type_and_sign():
    xs = np.repeat(np.arange(4), 3)
    d = np.arange(12.0) + 5.0
    expected = footprint(xs, d, RIG, edge_columns=0)
    for columns in (xs.astype(np.uint8), xs.astype(np.int32)):
        np.testing.assert_array_equal(footprint(columns, d, RIG, edge_columns=0), expected)
    shifted = footprint(xs - 300, d, RIG, edge_columns=0)      # negative columns too: the table starts at the first
    np.testing.assert_allclose(shifted[:, 1], expected[:, 1])
    np.testing.assert_allclose(shifted[:, 0], expected[:, 0] - 300 * expected[:, 1] / RIG.focal_px)


@pytest.mark.parametrize("seed", range(5))
def test_close_points_agree_with_a_brute_force_count_beyond_one_block(seed):
    rng = np.random.default_rng(seed)
    first = rng.uniform(0.0, 3.0, (BLOCK_POINTS + 300, 2))
    second = rng.uniform(2.0, 5.0, (400, 2))
    gaps = np.hypot(first[:, None, 0] - second[None, :, 0], first[:, None, 1] - second[None, :, 1])
    assert close_points(first, second, 0.25) == (int((gaps.min(axis=1) <= 0.25).sum()),
                                                 int((gaps.min(axis=0) <= 0.25).sum()))


def test_no_points_are_close_to_an_empty_footprint():
    assert close_points(np.empty((0, 2)), np.ones((3, 2)), 1.0) == (0, 0)
    assert close_points(np.ones((3, 2)), np.empty((0, 2)), 1.0) == (0, 0)


def test_footprints_and_their_parameters_of_other_shapes_are_refused():
    with pytest.raises(InvalidInputError, match="\\(n, 2\\)"):
        close_points(np.ones((3, 3)), np.ones((3, 2)), 1.0)
    with pytest.raises(InvalidInputError, match="edge_columns"):
        footprint(np.arange(5), np.ones(5), RIG, edge_columns=-1)
    with pytest.raises(InvalidInputError, match="min_column_pixels"):
        footprint(np.arange(5), np.ones(5), RIG, min_column_pixels=0)


@pytest.mark.parametrize("seed", range(20))
def test_footprint_spans_match_a_column_by_column_reference(seed):
    xs, d, edge_columns, min_column_pixels, rng = _random_pixels(seed)
    quantile = float(rng.uniform(0.0, 0.5))
    kept = _column_by_column(xs, d, edge_columns, min_column_pixels, (lambda column: np.quantile(column, 1 - quantile),
                                                                      lambda column: np.quantile(column, quantile)))
    fb = RIG.focal_baseline_px_m
    expected = np.array([((x - RIG.cx_px) / RIG.focal_px * fb / near, fb / near,
                          (x - RIG.cx_px) / RIG.focal_px * fb / far, fb / far) for x, near, far in kept])
    spans = footprint_spans(xs, d, RIG, quantile=quantile, edge_columns=edge_columns,
                            min_column_pixels=min_column_pixels)
    np.testing.assert_allclose(spans, expected, rtol=1e-12)
    points = footprint(xs, d, RIG, edge_columns=edge_columns, min_column_pixels=min_column_pixels)
    assert np.all((spans[:, 1] <= points[:, 1]) & (points[:, 1] <= spans[:, 3]))   # each point within its span


def test_footprint_spans_at_the_median_are_the_footprint_points():
    xs = np.repeat(np.arange(150, 162), 5)
    d = np.random.default_rng(1).uniform(8.0, 12.0, xs.shape)
    spans = footprint_spans(xs, d, RIG, quantile=0.5)
    points = footprint(xs, d, RIG)
    np.testing.assert_allclose(spans[:, 0:2], points, rtol=1e-12)
    np.testing.assert_allclose(spans[:, 2:4], points, rtol=1e-12)


def test_footprint_spans_leave_out_columns_whose_far_end_is_at_or_behind_infinity():
    xs = np.repeat(np.arange(4), 4)
    d = np.tile([0.0, 10.0, 10.0, 10.0], 4)                 # a quarter of each column at infinity
    assert len(footprint_spans(xs, d, RIG, quantile=0.1, edge_columns=0)) == 4   # at 3 px (interpolated)
    assert len(footprint_spans(xs, d, RIG, quantile=0.0, edge_columns=0)) == 0
    assert len(footprint_spans(xs, d, replace(RIG, doffs_px=1.0), quantile=0.0, edge_columns=0)) == 4
    tiny = np.tile([1e-320, 10.0, 10.0, 10.0], 4)           # positive, but its depth overflows
    assert len(footprint_spans(xs, tiny, RIG, quantile=0.0, edge_columns=0)) == 0
    assert np.isfinite(footprint_spans(xs, tiny, RIG, quantile=0.1, edge_columns=0)).all()
    assert len(footprint(xs, np.full(16, 1e-320), RIG, edge_columns=0)) == 0


def _on_sight_line(sideways, z_near_m, z_far_m):
    """A span ``(X near, Z near, X far, Z far)`` on the line of sight ``X = sideways * Z``."""
    return np.array([[sideways * z_near_m, z_near_m, sideways * z_far_m, z_far_m]])


def test_close_spans_measure_the_least_distance_between_two_segments():
    front = _on_sight_line(0.0, 2.0, 2.1)
    assert close_spans(front, _on_sight_line(0.0, 2.35, 3.0), 0.3) == (1, 1)    # 0.25 m behind
    assert close_spans(front, _on_sight_line(0.0, 2.45, 3.0), 0.3) == (0, 0)    # 0.35 m behind
    assert close_spans(_on_sight_line(0.0, 2.45, 3.0), front, 0.3) == (0, 0)    # either way round
    assert close_spans(front, _on_sight_line(0.0, 1.0, 2.05), 0.0) == (1, 1)    # overlapping: no gap
    # off the optical axis the gap lies along the line of sight: 0.2 m of depth is 0.215 m there
    off_axis = 0.4
    assert close_spans(_on_sight_line(off_axis, 2.0, 2.1), _on_sight_line(off_axis, 2.3, 3.0), 0.22) == (1, 1)
    assert close_spans(_on_sight_line(off_axis, 2.0, 2.1), _on_sight_line(off_axis, 2.3, 3.0), 0.21) == (0, 0)
    # segments side by side: the gap is from the shorter one's ends to the longer one's middle
    side = np.array([[0.2, 2.4, 0.2, 2.6]])
    assert close_spans(np.array([[0.0, 2.0, 0.0, 3.0]]), side, 0.21) == (1, 1)
    assert close_spans(np.array([[0.0, 2.0, 0.0, 3.0]]), side, 0.19) == (0, 0)


def _sampled_gap(a, b, samples=801):
    """The least distance between two segments ``(x0, z0, x1, z1)`` over ``samples`` evenly spaced
    points of each (ends included): at most ``(|a| + |b|) / (2 (samples - 1))`` above the true one."""
    t = np.linspace(0.0, 1.0, samples)[:, None]
    on_a = a[:2] + t * (a[2:] - a[:2])
    on_b = b[:2] + t * (b[2:] - b[:2])
    return float(np.min(np.hypot(on_a[:, None, 0] - on_b[None, :, 0], on_a[:, None, 1] - on_b[None, :, 1])))


def _awkward_segment_pairs(rng):
    """Pairs of segments that cross, touch, lie on one line (apart or overlapping), run parallel
    or have no length, and random ones."""
    pairs = [([0, 0, 2, 2], [0, 2, 2, 0]), ([0, 0, 2, 0], [1, 0, 1, 1]), ([0, 0, 1, 0], [1, 0, 2, 0]),
             ([0, 0, 1, 1], [2, 2, 3, 3]), ([0, 0, 2, 2], [1, 1, 3, 3]), ([0, 0, 1, 0], [0, 0.5, 1, 0.5]),
             ([1, 1, 1, 1], [0, 0, 2, 0]), ([1, 1, 1, 1], [1.5, 1, 1.5, 1]), ([0, 0, 2, 2], [1, 1.0000001, 5, 1]),
             ([0.3, 1.0, 0.3, 1.1], [0.3, 1.0, 0.3, 1.1])]
    pairs += [(rng.uniform(-3, 3, 4), rng.uniform(-3, 3, 4)) for _ in range(300)]
    return [(np.array(a, dtype=np.float64), np.array(b, dtype=np.float64)) for a, b in pairs]


def test_segment_gaps_agree_with_dense_sampling():
    from stereo_obstacles._footprints_kernel import segment_gap
    for a, b in _awkward_segment_pairs(np.random.default_rng(5)):
        bound = (np.hypot(*(a[2:] - a[:2])) + np.hypot(*(b[2:] - b[:2]))) / 1600 + 1e-12
        for first, second in ((a, b), (b, a)):
            gap = segment_gap(first, second)
            assert 0.0 <= _sampled_gap(first, second) - gap <= bound, (first, second, gap)


def test_two_spans_of_one_column_are_as_far_apart_as_their_depths():
    # on one line of sight the cross products are rounding noise: it must not make them cross
    from stereo_obstacles._footprints_kernel import segment_gap
    rng = np.random.default_rng(11)
    for _ in range(20000):
        sideways, z = rng.uniform(-1.0, 1.0), np.sort(rng.uniform(1.0, 60.0, 4))
        near, far = _on_sight_line(sideways, z[0], z[1])[0], _on_sight_line(sideways, z[2], z[3])[0]
        np.testing.assert_allclose(segment_gap(near, far), (z[2] - z[1]) * np.hypot(1.0, sideways), rtol=1e-9)


@pytest.mark.parametrize("seed", range(3))
def test_close_spans_count_the_spans_within_the_gap_of_any_other(seed):
    from stereo_obstacles._footprints_kernel import segment_gap
    rng = np.random.default_rng(seed)
    first = rng.uniform(0.0, 3.0, (300, 4))
    second = rng.uniform(1.0, 4.0, (40, 4))
    second[:3, 2:] = second[:3, :2]                          # three of no length
    gaps = np.array([[segment_gap(a, b) for b in second] for a in first])
    for max_gap_m in (0.05, 0.25):
        assert close_spans(first, second, max_gap_m) == (int((gaps.min(axis=1) <= max_gap_m).sum()),
                                                         int((gaps.min(axis=0) <= max_gap_m).sum()))
    assert close_spans(np.empty((0, 4)), second, 1.0) == (0, 0)
    # collinear on the 45 degree line, 0.2 m apart in X and in Z: 0.28 m apart
    assert close_spans(np.array([[1.0, 1.0, 1.1, 1.1]]), np.array([[1.3, 1.3, 2.0, 2.0]]), 0.25) == (0, 0)
    assert close_spans(np.array([[1.0, 1.0, 1.1, 1.1]]), np.array([[1.3, 1.3, 2.0, 2.0]]), 0.29) == (1, 1)


def test_spans_of_other_shapes_and_quantiles_out_of_range_are_refused():
    with pytest.raises(InvalidInputError, match="\\(n, 4\\) arrays of spans"):
        close_spans(np.ones((3, 3)), np.ones((3, 4)), 1.0)
    for quantile in (-0.1, 0.6, float("nan"), "0.25", True):
        with pytest.raises(InvalidInputError, match="quantile must be a number in \\[0, 0.5\\]"):
            footprint_spans(np.arange(5), np.ones(5), RIG, quantile=quantile)
    with pytest.raises(InvalidInputError, match="1-D arrays of one length"):
        footprint_spans(np.arange(5), np.ones(4), RIG, quantile=0.25)
