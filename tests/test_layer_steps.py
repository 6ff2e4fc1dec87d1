"""Whether the tight layers of a group meet with a step (two objects) or without (one surface)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.layer_steps import layer_surfaces


def _pixels(d: np.ndarray, layer: np.ndarray):
    ys, xs = np.nonzero(np.isfinite(d))
    return ys, xs, d[ys, xs], layer[ys, xs]


def _bands(d: np.ndarray, edges: list[int]) -> np.ndarray:
    """Layer of each pixel: which of the column ranges between ``edges`` it lies in."""
    return np.broadcast_to(np.searchsorted(edges, np.arange(d.shape[1]), side="right") - 1, d.shape).copy()


def test_the_bands_of_a_slanted_surface_are_one_surface():
    d = np.broadcast_to(np.linspace(6.0, 9.0, 120), (40, 120)).copy()    # 0.025 px per column
    ys, xs, values, layer = _pixels(d, _bands(d, [0, 40, 80]))
    assert layer_surfaces(ys, xs, values, layer, 3, 0.3).tolist() == [0, 0, 0]


def test_a_step_between_two_layers_separates_them_and_only_them():
    d = np.full((40, 120), 7.0)
    d[:, 40:80] += 0.02 * np.arange(40)      # the middle layer recedes into the left one without a step
    d[:, 80:] = 8.2                          # the right one stands 0.4 px nearer than the middle's edge
    ys, xs, values, layer = _pixels(d, _bands(d, [0, 40, 80]))
    assert layer_surfaces(ys, xs, values, layer, 3, 0.3).tolist() == [0, 0, 1]
    assert layer_surfaces(ys, xs, values, layer, 3, 0.5).tolist() == [0, 0, 0]


def test_the_median_of_the_boundary_decides_not_its_largest_step():
    d = np.full((40, 80), 7.0)
    d[:, 40:] = 7.1
    d[:15, 40] = 9.0                          # a few noisy pixels along the boundary
    ys, xs, values, layer = _pixels(d, _bands(d, [0, 40]))
    assert layer_surfaces(ys, xs, values, layer, 2, 0.3).tolist() == [0, 0]
    d[:25, 40] = 9.0                          # most of it
    ys, xs, values, layer = _pixels(d, _bands(d, [0, 40]))
    assert layer_surfaces(ys, xs, values, layer, 2, 0.3).tolist() == [0, 1]


def test_layers_that_do_not_touch_stay_apart():
    d = np.full((40, 120), 7.0)
    layer = _bands(d, [0, 40, 80])
    layer[:, 40:80] = -1                      # the pixels between them are in no layer
    ys, xs, values, layer_of = _pixels(d, layer)
    assert layer_surfaces(ys, xs, values, layer_of, 3, 0.3).tolist() == [0, 1, 2]


def test_touching_diagonally_is_not_touching():
    d = np.full((2, 2), 7.0)
    layer = np.array([[0, -1], [-1, 1]])
    ys, xs, values, layer_of = _pixels(d, layer)
    assert layer_surfaces(ys, xs, values, layer_of, 2, 0.3).tolist() == [0, 1]


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 6), st.integers(0, 2 ** 32 - 1))
def test_surfaces_are_numbered_from_zero_by_first_layer(n_layers, seed):
    rng = np.random.default_rng(seed)
    d = rng.uniform(5.0, 9.0, (12, 16))
    layer = rng.integers(-1, n_layers, d.shape)
    layer.flat[:n_layers] = np.arange(n_layers)                     # every layer present
    ys, xs, values, layer_of = _pixels(d, layer)
    surface = layer_surfaces(ys, xs, values, layer_of, n_layers, float(rng.uniform(0.0, 2.0)))
    assert surface.shape == (n_layers,) and surface[0] == 0
    firsts = [int(np.flatnonzero(surface == k)[0]) for k in range(surface.max() + 1)]
    assert firsts == sorted(firsts)


def test_a_step_of_exactly_the_minimum_is_no_step():
    d = np.full((20, 40), 7.0)
    d[:, 20:] = 7.5
    ys, xs, values, layer = _pixels(d, _bands(d, [0, 20]))
    assert layer_surfaces(ys, xs, values, layer, 2, 0.5).tolist() == [0, 0]
    assert layer_surfaces(ys, xs, values, layer, 2, 0.25).tolist() == [0, 1]


def test_layers_joined_through_others_are_one_surface_whatever_their_numbers():
    d = np.full((20, 80), 7.0)
    d[:, 60:] = 8.0                                        # bands numbered 0, 3, 2, 1; a step before the last
    layer = _bands(d, [0, 20, 40, 60])
    layer = np.array([0, 3, 2, 1])[layer]
    ys, xs, values, layer_of = _pixels(d, layer)
    assert layer_surfaces(ys, xs, values, layer_of, 4, 0.3).tolist() == [0, 1, 0, 0]


def test_a_surface_joined_twice_carries_all_its_layers():
    d = np.full((20, 80), 7.0)                             # no step anywhere
    layer = np.array([1, 3, 2, 0])[_bands(d, [0, 20, 40, 60])]
    ys, xs, values, layer_of = _pixels(d, layer)
    surface = layer_surfaces(ys, xs, values, layer_of, 4, 0.3)
    assert surface.tolist() == [0, 0, 0, 0] and surface.dtype == np.int64


@pytest.mark.parametrize("change, message", [
    (lambda a: {**a, "layer": np.array([0, 2])}, "layers must lie in -1..1"),
    (lambda a: {**a, "layer": np.array([-2, 0])}, "layers must lie in"),
    (lambda a: {**a, "n_layers": 0}, "layers must lie in"),
    (lambda a: {**a, "xs": np.array([0])}, "as many columns"),
    (lambda a: {k: v[:0] if isinstance(v, np.ndarray) else v for k, v in a.items()}, "one or more pixels"),
])
def test_bad_input_is_one_clear_error(change, message):
    given = {"ys": np.zeros(2, int), "xs": np.arange(2), "d": np.array([7.0, 7.1]), "layer": np.array([0, 1]),
             "n_layers": 2, "min_step_px": 0.3}
    with pytest.raises(InvalidInputError, match=message):
        layer_surfaces(**change(given))
