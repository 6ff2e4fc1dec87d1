"""Seeds: edge pixels, random pixels, scanline matching and user lists."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import gcs_reference as ref
from stereo_obstacles._edge_cells_kernel import strongest_per_cell
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.seeds import NOT_SCANNED, edge_pixels, find_seeds, match_pixels, random_pixels, user_seeds
from stereo_obstacles.similarity import prepare_similarity


def _pair(shift=4, shape=(20, 40), seed=0):
    rng = np.random.default_rng(seed)
    base = rng.uniform(0, 255, (shape[0], shape[1] + shift)).astype(np.float32)
    return base[:, :shape[1]].copy(), base[:, shift:].copy()   # left x matches right x - shift


def test_edges_on_a_step():
    img = np.zeros((20, 30), np.float32)
    img[:, 15:] = 200
    for method in ("canny", "sobel"):
        ys, xs = edge_pixels(img, method)
        assert len(xs) > 0 and np.all(np.abs(xs - 14.5) <= 2)
    assert len(edge_pixels(np.zeros((20, 30), np.float32))[0]) == 0
    with pytest.raises(InvalidInputError, match="method"):
        edge_pixels(img, "laplace")


def test_random_pixels_reproducible_and_distinct():
    a = random_pixels((10, 10), 30, rng_seed=5)
    b = random_pixels((10, 10), 30, rng_seed=5)
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    assert len(set(zip(a[0].tolist(), a[1].tolist()))) == 30


def test_scanline_matching_finds_the_shift_and_equals_brute_force():
    left, right = _pair(shift=4)
    inputs = prepare_similarity(left, right)
    ys = np.array([5, 10, 15, 3], np.int32)
    xs = np.array([20, 30, 10, 2], np.int32)
    seeds = match_pixels(inputs, ys, xs, d_min=0, d_max=8, tau=0.6, margin=0.1)
    assert seeds.n_candidates == 4
    assert seeds.n_evaluated == 9 + 9 + 9 + 3       # x=2 admits only d <= 2
    assert np.all(seeds.x - seeds.x_right == 4)      # x=2 cannot reach d=4 and is dropped
    assert len(seeds) == 3
    for y, x, c in zip(seeds.y, seeds.x, seeds.similarity):
        brute = max(ref.similarity(left, right, y, x, x - d) for d in range(0, min(8, x) + 1))
        assert c == pytest.approx(brute, abs=1e-5)
    for n_threads in (2, 3, 5):  # chunks searched in threads: the same seeds and counts
        threaded = match_pixels(inputs, ys, xs, d_min=0, d_max=8, tau=0.6, margin=0.1, n_threads=n_threads)
        for field in ("y", "x", "x_right", "similarity", "scanned_hi"):
            np.testing.assert_array_equal(getattr(threaded, field), getattr(seeds, field))
        assert threaded.n_evaluated == seeds.n_evaluated
    with pytest.raises(InvalidInputError, match="n_threads"):
        match_pixels(inputs, ys, xs, d_min=0, d_max=8, tau=0.6, margin=0.1, n_threads=0)


def test_ambiguous_pixels_are_not_seeds():
    stripe = np.tile(np.array([0, 200, 50, 120], np.float32), 10)
    img = np.tile(stripe, (12, 1))
    inputs = prepare_similarity(img, img)
    seeds = match_pixels(inputs, np.array([6], np.int32), np.array([30], np.int32), d_min=0, d_max=10,
                         tau=0.6, margin=0.1)
    assert len(seeds) == 0          # d = 0, 4 and 8 all fit perfectly


def test_find_seeds_sources_and_user_list():
    left, right = _pair(shift=3, seed=1)
    inputs = prepare_similarity(left, right)
    for source in ("canny", "sobel", "random"):
        s = find_seeds(inputs, left, source, d_min=0, d_max=8, tau=0.6, margin=0.1)
        assert len(s) > 0 and np.median(s.x - s.x_right) == 3
    with pytest.raises(InvalidInputError, match="seeds"):
        find_seeds(inputs, left, "harris", d_min=0, d_max=8, tau=0.6, margin=0.1)
    u = user_seeds(inputs, np.array([[10, 5, 3], [20, 6, 1]]), d_min=0, d_max=8)
    assert u.similarity[0] > 0.99 > u.similarity[1]
    with pytest.raises(InvalidInputError, match="shape"):
        user_seeds(inputs, np.array([1, 2, 3]), d_min=0, d_max=8)
    with pytest.raises(InvalidInputError, match="outside"):
        user_seeds(inputs, np.array([[1, 5, 3]]), d_min=0, d_max=8)


def test_edge_spacing_keeps_the_strongest_edge_pixel_per_cell():
    rng = np.random.default_rng(3)
    img = rng.uniform(0, 255, (37, 53)).astype(np.float32)
    all_ys, all_xs = edge_pixels(img, "canny")
    spacing = 6
    ys, xs = edge_pixels(img, "canny", spacing)
    edges = set(zip(all_ys.tolist(), all_xs.tolist()))
    assert set(zip(ys.tolist(), xs.tolist())) <= edges           # a subset of the edge pixels
    cells = list(zip((ys // spacing).tolist(), (xs // spacing).tolist()))
    assert len(set(cells)) == len(cells)                        # at most one per cell
    assert set(cells) == {(y // spacing, x // spacing) for y, x in edges}   # every cell with an edge
    gx = cv2.Sobel(img, cv2.CV_32F, 1, 0, ksize=3)
    gy = cv2.Sobel(img, cv2.CV_32F, 0, 1, ksize=3)
    mag = np.hypot(gx, gy)
    for y, x in zip(ys, xs):                                    # the strongest of its cell
        in_cell = [mag[v, u] for v, u in edges if v // spacing == y // spacing and u // spacing == x // spacing]
        assert mag[y, x] == pytest.approx(max(in_cell), rel=1e-5)
    with pytest.raises(InvalidInputError, match="spacing"):
        edge_pixels(img, "canny", 0)


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 25), st.integers(1, 25), st.integers(1, 7), st.integers(0, 2 ** 31 - 1))
def test_strongest_per_cell_kernel_agrees_with_a_plain_loop(h, w, spacing, rng_seed):
    rng = np.random.default_rng(rng_seed)
    edges = rng.random((h, w)) < 0.4
    magnitude = rng.integers(0, 4, (h, w)).astype(np.float32)   # few levels: many ties
    expected = []
    for y0 in range(0, h, spacing):
        for x0 in range(0, w, spacing):
            pixels = [(y, x) for y in range(y0, min(y0 + spacing, h)) for x in range(x0, min(x0 + spacing, w))
                      if edges[y, x]]
            if pixels:   # the first of the strongest, in raster order inside the cell
                expected.append(max(pixels, key=lambda p: (magnitude[p], -p[0], -p[1])))
    expected.sort()
    ys, xs = strongest_per_cell(edges, magnitude, spacing)
    assert ys.dtype == xs.dtype == np.int32
    assert list(zip(ys.tolist(), xs.tolist())) == expected


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 30), st.integers(1, 30), st.integers(1, 9), st.integers(0, 2 ** 31 - 1))
def test_thinned_sobel_edges_are_the_strongest_sobel_edge_pixel_of_each_cell(h, w, spacing, rng_seed):
    img = (np.random.default_rng(rng_seed).integers(0, 4, (h, w)) * 60).astype(np.float32)  # many ties
    gx = cv2.Sobel(img, cv2.CV_32F, 1, 0, ksize=3)
    gy = cv2.Sobel(img, cv2.CV_32F, 0, 1, ksize=3)
    edges = np.zeros((h, w), bool)
    edges[edge_pixels(img, "sobel")] = True
    expected = strongest_per_cell(edges, np.sqrt(gx * gx + gy * gy), spacing)
    ys, xs = edge_pixels(img, "sobel", spacing)
    np.testing.assert_array_equal(ys, expected[0])
    np.testing.assert_array_equal(xs, expected[1])


def test_scanned_pixels_are_recorded_for_visit_counting():
    left, right = _pair(shift=4)
    inputs = prepare_similarity(left, right)
    seeds = match_pixels(inputs, np.array([5, 3], np.int32), np.array([20, 2], np.int32), d_min=1, d_max=8,
                         tau=0.6, margin=0.1)
    expected = np.full(left.shape, NOT_SCANNED)
    expected[5, 20] = 8
    expected[3, 2] = 2
    np.testing.assert_array_equal(seeds.scanned_hi, expected)
