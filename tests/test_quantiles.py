"""The quick percentiles and medians equal NumPy's to the bit, in NumPy's types."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from stereo_obstacles.quantiles import median, median_of_sorted, percentile, percentile_of_sorted, percentiles

VALUES = hnp.arrays(np.float64, st.integers(1, 60),
                    elements=st.floats(-1e300, 1e300, allow_nan=False, allow_infinity=False))


@settings(max_examples=300, deadline=None)
@given(VALUES, st.floats(0.0, 100.0))
@example(np.array([-535669373161110.94, 104900117.15303971]), 50.0)   # t = 0.5: only b - (b - a)(1 - t) is NumPy's
@example(np.array([0.1, 0.7, 0.3, 0.9]), 99.0)
@example(np.array([5.0]), 0.0)
def test_equal_to_numpy(values, q):
    ordered = np.sort(values)
    want = np.percentile(values, q)
    assert percentile_of_sorted(ordered, q) == want
    assert percentile(values, q) == want
    assert median_of_sorted(ordered) == np.median(values)


@pytest.mark.parametrize("q", [0.0, 1.0, 10.0, 25.0, 50.0, 75.0, 99.0, 100.0])
def test_equal_to_numpy_on_many_values_with_repeats(q):
    rng = np.random.default_rng(int(q))
    values = np.round(rng.normal(5.0, 2.0, 4001), 1)      # many ties, as depths in a patch
    assert percentile(values, q) == np.percentile(values, q)
    assert percentile_of_sorted(np.sort(values), q) == np.percentile(values, q)
    assert median_of_sorted(np.sort(values[:-1])) == np.median(values[:-1])   # an even count


FLOAT32_VALUES = hnp.arrays(np.float32, st.integers(1, 60),
                            elements=st.floats(-2.0 ** 100, 2.0 ** 100, width=32))
UINT8_VALUES = hnp.arrays(np.uint8, st.integers(1, 60))
BOOL_VALUES = hnp.arrays(np.bool_, st.integers(1, 60))


@settings(max_examples=300, deadline=None)
@given(st.one_of(VALUES, FLOAT32_VALUES, UINT8_VALUES), st.floats(0.0, 100.0), st.floats(0.0, 100.0))
@example(np.array([0.1, 0.7], dtype=np.float32), 30.0, 70.0)
@example(np.array([250, 255], dtype=np.uint8), 50.0, 50.0)      # the sum of the middle values overflows uint8
def test_equal_to_numpy_in_its_types(values, q, other_q):
    """float32 arrays are interpolated in float32 for one q and in float64 for a list of q;
    the median of uint8 values is taken in float64."""
    ordered = np.sort(values)
    assert percentile(values, q) == np.percentile(values, q)
    assert percentile_of_sorted(ordered, q) == np.percentile(values, q)
    assert percentiles(values, (q, 50.0, other_q)) == tuple(np.percentile(values, [q, 50.0, other_q]))
    assert median(values) == np.median(values)
    assert median_of_sorted(ordered) == np.median(values)


@pytest.mark.parametrize("n", [1, 2, 7, 1000, 46_080])
def test_float32_values_like_the_reference_area(n):
    values = np.random.default_rng(n).uniform(0, 50, n).astype(np.float32)
    assert median(values) == np.median(values)
    for q in (0.0, 5.0, 37.5, 80.0, 95.0, 100.0):
        assert percentile(values, q) == np.percentile(values, q)
    assert percentiles(values, (5.0, 50.0, 95.0)) == tuple(np.percentile(values, [5.0, 50.0, 95.0]))


@settings(max_examples=100, deadline=None)
@given(BOOL_VALUES)
@example(np.array([False, True, True, True]))                   # True + True is not 2 in bool
def test_median_of_booleans_equal_to_numpy(values):
    """NumPy takes no percentile of booleans, but their median: the mean in float64."""
    assert median(values) == np.median(values)
    assert median_of_sorted(np.sort(values)) == np.median(values)


def test_empty_input_raises_instead_of_returning_nan():
    with pytest.raises(ValueError):
        median(np.array([], dtype=np.float32))
