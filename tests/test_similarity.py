"""Window similarity (NCC/MNCC) against the definition, and its guards."""

from __future__ import annotations

import numpy as np
import pytest

import gcs_reference as ref
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.similarity import UNDEFINED, prepare_similarity, similarity_at, to_grey


@pytest.mark.parametrize("kind", ["ncc", "mncc"])
def test_similarity_equals_definition_including_borders(kind):
    rng = np.random.default_rng(0)
    left = rng.uniform(0, 255, (12, 15)).astype(np.float32)
    right = rng.uniform(0, 255, (12, 15)).astype(np.float32)
    inputs = prepare_similarity(left, right, kind=kind)
    ys, xs, xrs = np.meshgrid(np.arange(12), np.arange(15), np.arange(0, 15, 4), indexing="ij")
    got = similarity_at(inputs, ys, xs, xrs)
    expected = np.vectorize(lambda y, x, xr: ref.similarity(left, right, y, x, xr, kind))(ys, xs, xrs)
    np.testing.assert_allclose(got, expected, atol=2e-5)


def test_ncc_invariant_to_gain_and_offset_mncc_not_to_gain():
    rng = np.random.default_rng(1)
    img = rng.uniform(0, 100, (10, 10)).astype(np.float32)
    for kind, expected in (("ncc", 1.0), ("mncc", 2 * 2 / (1 + 4))):
        s = prepare_similarity(img, 2 * img + 30, kind=kind)
        assert float(similarity_at(s, np.array(5), np.array(5), np.array(5))) == pytest.approx(expected, abs=1e-5)


def test_flat_windows_are_undefined():
    img = np.zeros((10, 20), np.float32)
    img[:, 10:] = np.random.default_rng(2).uniform(0, 255, (10, 10))
    s = prepare_similarity(img, img, min_std=1.0)
    assert similarity_at(s, np.array(5), np.array(3), np.array(3)) == UNDEFINED
    assert similarity_at(s, np.array(5), np.array(15), np.array(15)) == pytest.approx(1.0)


def test_large_offsets_do_not_lose_precision():
    rng = np.random.default_rng(3)
    img = (60000 + rng.uniform(0, 4, (10, 10))).astype(np.float32)   # uint16-like, tiny contrast
    s = prepare_similarity(img, img)
    assert float(similarity_at(s, np.array(5), np.array(5), np.array(5))) == pytest.approx(1.0, abs=1e-3)


def test_to_grey_and_errors():
    rgb = np.zeros((4, 5, 3), np.uint8)
    rgb[..., 1] = 100
    assert to_grey(rgb).shape == (4, 5)
    assert to_grey(rgb)[0, 0] == pytest.approx(58.7)
    with pytest.raises(InvalidInputError, match="shape"):
        to_grey(np.zeros((4, 5, 2)))
    with pytest.raises(InvalidInputError, match="NaN"):
        to_grey(np.full((4, 5), np.nan))
    with pytest.raises(InvalidInputError, match="similarity"):
        prepare_similarity(np.zeros((5, 5), np.float32), np.zeros((5, 5), np.float32), kind="sad")
    s = prepare_similarity(np.zeros((5, 5), np.float32), np.zeros((5, 5), np.float32))
    with pytest.raises(InvalidInputError, match="points"):
        similarity_at(s, np.array(0), np.array(5), np.array(0))


@pytest.mark.parametrize("kind", ["ncc", "mncc"])
def test_two_threads_prepare_the_same_inputs(kind):
    rng = np.random.default_rng(3)
    left, right = rng.uniform(0, 255, (2, 30, 40)).astype(np.float32)
    one = prepare_similarity(left, right, kind=kind)
    two = prepare_similarity(left, right, kind=kind, n_threads=2)
    for a, b in zip(one.kernel_args(), two.kernel_args()):
        np.testing.assert_array_equal(a, b)
    with pytest.raises(InvalidInputError, match="n_threads"):
        prepare_similarity(left, right, n_threads=0)


@pytest.mark.parametrize("shape", [(20, 25), (5, 5), (6, 9)])
def test_padded_images_mirror_the_float32_centred_image(shape):
    rng = np.random.default_rng(6)
    left, right = rng.uniform(0, 255, (2, *shape)).astype(np.float32)
    inputs = prepare_similarity(left, right)
    for grey, pad in ((left, inputs.left_pad), (right, inputs.right_pad)):
        centred32 = (grey.astype(np.float64) - float(grey.mean())).astype(np.float32)
        assert pad.dtype == np.float64
        np.testing.assert_array_equal(pad, np.pad(centred32, 2, mode="reflect").astype(np.float64))


def test_mncc_norm_is_the_window_variance():
    rng = np.random.default_rng(5)
    grey = rng.uniform(0, 255, (12, 16)).astype(np.float32)
    inputs = prepare_similarity(grey, grey, kind="mncc")
    centred = np.pad(grey.astype(np.float64) - float(grey.mean()), 2, mode="reflect")
    windows = np.lib.stride_tricks.sliding_window_view(centred, (5, 5))
    np.testing.assert_allclose(inputs.norm_l, windows.var(axis=(2, 3)), rtol=1e-5)


def test_window_norms_equal_the_numpy_expressions():
    rng = np.random.default_rng(4)
    grey = rng.uniform(0, 255, (20, 25)).astype(np.float32)
    grey[5:15, 5:15] = 7.0  # flat windows
    inputs = prepare_similarity(grey, grey)
    centred = np.pad(grey.astype(np.float64) - float(grey.mean()), 2, mode="reflect")
    windows = np.lib.stride_tricks.sliding_window_view(centred, (5, 5))
    var = windows.var(axis=(2, 3))
    np.testing.assert_allclose(inputs.mean_l, windows.mean(axis=(2, 3)), atol=1e-4)
    flat = var < 1.0
    assert flat.any() and not flat.all()
    np.testing.assert_array_equal(inputs.norm_l[flat], 0.0)
    np.testing.assert_allclose(inputs.norm_l[~flat], 1.0 / np.sqrt(var[~flat]), rtol=1e-5)


@pytest.mark.parametrize("left, right, message", [
    (np.zeros((0, 5), np.float32), np.zeros((0, 5), np.float32), "left_grey"),
    (np.zeros((4, 5), np.float32), np.zeros((4, 6), np.float32), "differ in size"),
    (np.zeros((4, 5, 3), np.float32), np.zeros((4, 5, 3), np.float32), "left_grey"),
    (np.zeros((4, 5), bool), np.zeros((4, 5), bool), "left_grey"),
])
def test_prepare_refuses_what_is_not_a_pair_of_grey_images(left, right, message):
    with pytest.raises(InvalidInputError, match=message):
        prepare_similarity(left, right)


def test_prepare_takes_one_pixel_and_integer_images():
    one = prepare_similarity(np.full((1, 1), 9, np.uint8), np.full((1, 1), 9, np.uint8))
    assert one.left_pad.shape == (5, 5) and float(one.norm_l[0, 0]) == 0.0   # flat: never matched
    rng = np.random.default_rng(7)
    grey = rng.integers(0, 256, (9, 11), dtype=np.uint8)
    np.testing.assert_array_equal(prepare_similarity(grey, grey).norm_l,
                                  prepare_similarity(grey.astype(np.float32), grey.astype(np.float32)).norm_l)
