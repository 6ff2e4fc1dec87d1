"""The compiled parabola vertex against the formula written with NumPy."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from stereo_obstacles.subpixel import parabola_offset


def _numpy_reference(cm, c, cp):
    cm, c, cp = (np.asarray(a, np.float64) for a in (cm, c, cp))
    curvature = cm - 2.0 * c + cp
    peak = np.isfinite(curvature) & (curvature < 0.0)
    offset = np.where(peak, 0.5 * (cm - cp) / np.where(peak, curvature, -1.0), 0.0)
    return np.clip(np.nan_to_num(offset), -0.5, 0.5).astype(np.float32)


similarities = st.one_of(st.floats(-1.0, 1.0, width=32), st.just(float("nan")))


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(similarities, similarities, similarities), min_size=1, max_size=40))
def test_same_bits_as_the_numpy_formula(triples):
    cm, c, cp = (np.array(v, np.float32) for v in zip(*triples))
    np.testing.assert_array_equal(parabola_offset(cm, c, cp), _numpy_reference(cm, c, cp))


def test_shape_is_kept_and_scalars_broadcast():
    c = np.array([[1.0, 0.9], [0.8, 0.7]], np.float32)
    out = parabola_offset(0.5, c, np.full((2, 2), 0.5, np.float32))
    assert out.shape == (2, 2) and out.dtype == np.float32
    assert out[0, 0] == 0.0


def test_symmetric_peak_edges_and_missing_sides():
    out = parabola_offset(np.array([0.5, 0.0, np.nan, 1.0]), np.array([1.0, 1.0, 1.0, 1.0]),
                          np.array([0.5, 1.0, 0.5, 1.0]))
    np.testing.assert_array_equal(out, np.array([0.0, 0.5, 0.0, 0.0], np.float32))
