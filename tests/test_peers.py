"""The comparison matchers: OpenCV BM/SGBM wrappers and the exhaustive NCC winner-takes-all."""

from __future__ import annotations

import numpy as np
import pytest

from stereo_obstacles import peers
from stereo_obstacles.errors import ImageMismatchError, InvalidInputError


def _shifted_pair(shape, shift, seed=0, colour=True):
    """A random-texture right image and a left image that sees it shifted by ``shift`` px."""
    rng = np.random.default_rng(seed)
    h, w = shape
    base = rng.integers(0, 256, (h, w + shift, 3) if colour else (h, w + shift), dtype=np.uint8)
    right = np.ascontiguousarray(base[:, shift:])
    left = np.ascontiguousarray(base[:, :w])
    # left(x) = base(x), right(x') = base(x' + shift): left x matches right x - shift
    return left, right


def _reference_ncc_wta(left, right, d_max, radius, min_std):
    """Slow, obviously correct exhaustive NCC winner-takes-all with the parabola refinement."""
    grey_l = left.astype(np.float64)
    grey_r = right.astype(np.float64)
    h, w = grey_l.shape
    out = np.full((h, w), np.nan, dtype=np.float32)
    for y in range(radius, h - radius):
        for x in range(radius, w - radius):
            scores = np.full(d_max + 1, np.nan)
            a = grey_l[y - radius:y + radius + 1, x - radius:x + radius + 1]
            for d in range(d_max + 1):
                if x - d - radius < 0:
                    break
                b = grey_r[y - radius:y + radius + 1, x - d - radius:x - d + radius + 1]
                if a.std() < min_std or b.std() < min_std:
                    continue
                scores[d] = ((a - a.mean()) * (b - b.mean())).mean() / (a.std() * b.std())
            if np.all(np.isnan(scores)):
                continue
            best = int(np.nanargmax(scores))
            offset = 0.0
            if 0 < best < d_max and not np.isnan(scores[best - 1]) \
                    and not np.isnan(scores[best + 1]):
                cm, c0, cp = scores[best - 1], scores[best], scores[best + 1]
                denom = cm + cp - 2 * c0
                if denom < 0:
                    offset = 0.5 * (cm - cp) / denom
            out[y, x] = best + offset
    return out


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_ncc_kernel_matches_numpy_reference(seed):
    rng = np.random.default_rng(seed)
    # smooth-ish texture so that the parabola fit is exercised with real neighbours
    base = rng.integers(0, 256, (14, 30), dtype=np.uint8)
    left = base.copy()
    right = np.roll(base, -3, axis=1)
    right[:, :5] = 128  # a textureless patch: skipped by the std guard
    right[5:8, 10:20] = rng.integers(0, 256, (3, 10), dtype=np.uint8)
    expected = _reference_ncc_wta(left, right, d_max=6, radius=2, min_std=0.5)
    got = peers.ncc_wta_disparity(left, right, max_disparity=6)
    assert got.dtype == np.float32 and got.shape == left.shape
    np.testing.assert_array_equal(np.isnan(got), np.isnan(expected))
    np.testing.assert_allclose(got, expected, atol=1e-5, equal_nan=True)
    assert np.isfinite(got).sum() > 100


def test_ncc_recovers_a_known_shift_and_leaves_the_border_unmatched():
    left, right = _shifted_pair((30, 60), 5, colour=True)
    d = peers.ncc_wta_disparity(left, right, max_disparity=8)
    inner = d[2:-2, 5 + 2:-2]
    assert np.all(np.isfinite(inner))
    assert np.mean(np.abs(inner - 5) < 0.5) > 0.95
    assert np.all(np.isnan(d[:2])) and np.all(np.isnan(d[:, :2]))


def test_ncc_textureless_images_give_no_match():
    flat = np.full((20, 30, 3), 90, dtype=np.uint8)
    assert np.all(np.isnan(peers.ncc_wta_disparity(flat, flat, max_disparity=5)))


@pytest.mark.parametrize("matcher", [peers.sgbm_disparity, peers.bm_disparity])
@pytest.mark.parametrize("colour", [True, False])
def test_opencv_peers_recover_a_known_shift(matcher, colour):
    left, right = _shifted_pair((60, 120), 7, seed=3, colour=colour)
    d = matcher(left, right, max_disparity=12)
    assert d.dtype == np.float32 and d.shape == left.shape[:2]
    valid = np.isfinite(d)
    assert valid.mean() > 0.5
    assert np.mean(np.abs(d[valid] - 7) <= 1) > 0.95
    assert np.nanmin(d) >= 0  # invalid fixed-point values became NaN, not -1


def test_opencv_invalid_value_becomes_nan():
    raw = np.array([[-16, 0, 16, 40]], dtype=np.int16)
    out = peers._from_opencv(raw, min_disparity=0)
    assert np.isnan(out[0, 0])
    np.testing.assert_array_equal(out[0, 1:], [0.0, 1.0, 2.5])


@pytest.mark.parametrize(("max_d", "expected"), [(1, 16), (15, 16), (15.5, 32), (16, 32),
                                                 (52.75, 64), (211, 224)])
def test_num_disparities_is_a_multiple_of_16_covering_the_range(max_d, expected):
    assert peers.num_disparities_for(max_d) == expected


@pytest.mark.parametrize("matcher", [peers.sgbm_disparity, peers.bm_disparity,
                                     peers.ncc_wta_disparity])
def test_bad_input(matcher):
    left = np.zeros((20, 30, 3), np.uint8)
    with pytest.raises(ImageMismatchError, match="right image"):
        matcher(left, np.zeros((20, 31, 3), np.uint8), max_disparity=8)
    with pytest.raises(InvalidInputError, match="uint8"):
        matcher(left.astype(np.float32), left, max_disparity=8)
    with pytest.raises(InvalidInputError, match="max_disparity"):
        matcher(left, left, max_disparity=0)
    with pytest.raises(InvalidInputError, match="shape"):
        matcher(np.zeros((20, 30, 4), np.uint8), np.zeros((20, 30, 4), np.uint8),
                max_disparity=8)


def test_bad_block_sizes():
    left = np.zeros((20, 30), np.uint8)
    with pytest.raises(InvalidInputError, match="odd"):
        peers.sgbm_disparity(left, left, max_disparity=8, block_size=4)
    with pytest.raises(InvalidInputError, match=">= 5"):
        peers.bm_disparity(left, left, max_disparity=8, block_size=3)


@pytest.mark.shared_data
def test_sgbm_on_cones_is_close_to_the_published_figure(shared_dataset):
    from stereo_obstacles.datasets import load_pair
    from stereo_obstacles.disparity_metrics import evaluate_disparity

    pair = load_pair(shared_dataset("middlebury2003_cones"))
    d = peers.sgbm_disparity(pair.left, pair.right, max_disparity=pair.max_gt_disparity)
    m = evaluate_disparity(d, pair.gt_disparity, mask=pair.nonocc)
    # algorithm.md: SGBM on Cones 87 % dense, 3.7 % bad-1 over matched non-occluded
    assert m.density_pct > 80
    assert m.bad1_matched_pct < 6
