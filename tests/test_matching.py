"""The public GCS matcher: validation, shapes, known answers, real Middlebury accuracy."""

from __future__ import annotations

import inspect

import numpy as np
import pytest

from stereo_obstacles.errors import ImageMismatchError, InvalidInputError
from stereo_obstacles.fileio import read_image
from stereo_obstacles.matching import MatchResult, match


def _shifted_pair(shape=(48, 80), shift=5, seed=1):
    """A random-texture right image and the left image seeing it ``shift`` px to the right."""
    rng = np.random.default_rng(seed)
    right = rng.uniform(0, 255, shape).astype(np.float32)
    left = np.empty_like(right)
    left[:, shift:] = right[:, :-shift]
    left[:, :shift] = rng.uniform(0, 255, (shape[0], shift))
    return left, right


def test_constant_shift_is_recovered_exactly():
    left, right = _shifted_pair(shift=5)
    result = match(left, right, max_disparity=12)
    assert isinstance(result, MatchResult)
    assert result.disparity.shape == left.shape and result.disparity.dtype == np.float32
    assert result.similarity.dtype == np.float32
    valid = np.isfinite(result.disparity)
    assert valid.mean() > 0.85
    assert np.abs(result.disparity[valid] - 5).max() < 0.5
    assert np.all(np.isfinite(result.similarity) == valid)
    default_tau = inspect.signature(match).parameters["tau"].default
    assert np.nanmin(result.similarity) >= default_tau  # no match below the threshold


@pytest.mark.parametrize("variant", ["stable", "greedy"])
@pytest.mark.parametrize("similarity", ["ncc", "mncc"])
def test_variants_and_similarities_recover_shift(variant, similarity):
    left, right = _shifted_pair(shift=3, seed=2)
    result = match(left, right, max_disparity=8, variant=variant, similarity=similarity)
    valid = np.isfinite(result.disparity)
    assert valid.mean() > 0.85
    assert np.median(result.disparity[valid]) == pytest.approx(3, abs=0.1)


@pytest.mark.parametrize("seeds", ["canny", "sobel", "random"])
def test_seed_sources(seeds):
    left, right = _shifted_pair(shift=4, seed=3)
    result = match(left, right, max_disparity=8, seeds=seeds)
    assert result.stats.n_seeds > 0
    assert np.nanmedian(result.disparity) == pytest.approx(4, abs=0.1)


@pytest.mark.parametrize("seed_row", [2, 20, 45])
def test_user_seed_points_grow_from_one_seed(seed_row):
    left, right = _shifted_pair(shift=4, seed=4)  # 48 rows: the two default bands meet at row 26
    result = match(left, right, max_disparity=8, seed_points=np.array([[40, seed_row, 4]]))
    assert result.stats.n_seeds == 1
    assert np.isfinite(result.disparity).mean() > 0.8  # the band without the seed is grown too


def test_colour_and_uint8_input_accepted():
    left, right = _shifted_pair(shift=2, seed=5)
    l8 = np.repeat(left.astype(np.uint8)[..., None], 3, axis=2)
    r8 = np.repeat(right.astype(np.uint8)[..., None], 3, axis=2)
    result = match(l8, r8, max_disparity=6)
    assert np.nanmedian(result.disparity) == pytest.approx(2, abs=0.1)


@pytest.mark.parametrize("image", [np.zeros((30, 40), np.uint8), np.full((30, 40), 128.0)])
def test_textureless_gives_empty_result(image):
    result = match(image, image)
    assert np.isnan(result.disparity).all()
    assert result.stats.density == 0.0


def test_identical_images_match_at_zero_disparity_only():
    left, _ = _shifted_pair()
    result = match(left, left, max_disparity=10)
    valid = np.isfinite(result.disparity)
    assert valid.any()
    assert np.abs(result.disparity[valid]).max() < 0.5


def test_errors():
    a = np.zeros((20, 30), np.uint8)
    with pytest.raises(ImageMismatchError, match="differ in size"):
        match(a, np.zeros((20, 31), np.uint8))
    with pytest.raises(InvalidInputError, match="at least 5x5"):
        match(np.zeros((4, 30)), np.zeros((4, 30)))
    with pytest.raises(InvalidInputError, match="tau"):
        match(a, a, tau=1.5)
    with pytest.raises(InvalidInputError, match="variant"):
        match(a, a, variant="fast")
    with pytest.raises(InvalidInputError, match="seeds"):
        match(a, a, seeds="harris")
    with pytest.raises(InvalidInputError, match="max_disparity"):
        match(a, a, min_disparity=5, max_disparity=2)
    with pytest.raises(InvalidInputError, match="seed_points"):
        match(a, a, seed_points=np.array([[100, 5, 1]]))


def test_stats_dict_is_complete():
    left, right = _shifted_pair()
    stats = match(left, right, max_disparity=10).stats.to_dict()
    for key in ("n_seeds", "n_visited", "visited_fraction_full", "visited_fraction_range", "density",
                "prepare_seconds", "seeds_seconds", "growth_seconds", "final_seconds", "subpixel_seconds",
                "match_seconds"):
        assert key in stats
    assert 0 < stats["visited_fraction_range"] <= 1.5


def _bad1(shared_dataset, name, scale, **kw):
    folder = shared_dataset(name)
    left = read_image(folder / "imL.png", mode="color")
    right = read_image(folder / "imR.png", mode="color")
    gt = read_image(folder / "groundtruth.png", mode="gray").astype(np.float32) / scale
    mask = read_image(folder / "nonocc.png", mode="gray") == 255
    result = match(left, right, max_disparity=int(np.ceil(gt.max())) + 4, **kw)
    matched = mask & np.isfinite(result.disparity)
    bad = np.abs(result.disparity[matched] - gt[matched]) > 1
    return bad.mean(), matched.sum() / mask.sum()


@pytest.mark.shared_data
@pytest.mark.parametrize("name, scale, max_bad, min_density", [
    ("middlebury2003_cones", 4, 0.045, 0.80),
    ("middlebury2003_teddy", 4, 0.065, 0.75),
])
def test_middlebury_accuracy(shared_dataset, name, scale, max_bad, min_density):
    bad, density = _bad1(shared_dataset, name, scale)
    assert bad <= max_bad
    assert density >= min_density


def test_seed_spacing_is_validated():
    a = np.zeros((20, 30), np.uint8)
    with pytest.raises(InvalidInputError, match="seed_spacing"):
        match(a, a, seed_spacing=0)


def test_speckles_removed_from_the_result_and_counted():
    left, right = _shifted_pair(shape=(60, 90), shift=5, seed=6)
    left[20:34, 40:54] = right[20:34, 28:42]      # a 14 x 14 island at disparity 12 in a surface at 5
    kept = match(left, right, max_disparity=14, speckle_size=0)
    cleaned = match(left, right, max_disparity=14, speckle_size=196, speckle_range=1.0)
    assert kept.stats.n_speckle_removed == 0
    assert np.count_nonzero(np.abs(kept.disparity[20:34, 40:54] - 12) < 0.5) > 80
    assert 80 < cleaned.stats.n_speckle_removed <= 196
    assert not (np.abs(cleaned.disparity - 12) < 0.5).any()
    removed = np.isfinite(kept.disparity) & ~np.isfinite(cleaned.disparity)
    assert cleaned.stats.n_speckle_removed == np.count_nonzero(removed)
    assert not (np.isfinite(cleaned.disparity) & ~np.isfinite(kept.disparity)).any()
    assert np.array_equal(np.isfinite(cleaned.similarity), np.isfinite(cleaned.disparity))
    assert cleaned.stats.density * left.size == pytest.approx(np.count_nonzero(np.isfinite(cleaned.disparity)))
    # what is left has no speckle in it any more
    from stereo_obstacles.speckles import speckle_mask
    assert not speckle_mask(cleaned.disparity, max_size_px=196, max_difference_px=1.0).any()


@pytest.mark.parametrize("kwargs, message", [(dict(speckle_size=-1), "speckle_size"),
                                             (dict(speckle_size=1.5), "speckle_size"),
                                             (dict(speckle_range=-1.0), "speckle_range"),
                                             (dict(speckle_range=float("inf")), "speckle_range"),
                                             (dict(speckle_range=10 ** 400), "speckle_range"),
                                             (dict(speckle_size=True), "speckle_size"),
                                             (dict(speckle_size="5"), "speckle_size")])
def test_speckle_options_are_validated(kwargs, message):
    a = np.zeros((20, 30), np.uint8)
    with pytest.raises(InvalidInputError, match=message):
        match(a, a, **kwargs)


def test_matches_piling_up_at_the_largest_disparity_searched_are_warned_about(caplog):
    from stereo_obstacles.matching import CUT_OFF_FRACTION, warn_if_range_cut_off

    d = np.full((100, 100), 10.0, np.float32)
    d[:, :5] = np.nan
    d[:2, 10:20] = 63.7                              # 20 of 9500 matches at the limit: 0.21 %
    with caplog.at_level("WARNING", logger="stereo_obstacles.matching"):
        share = warn_if_range_cut_off(d, 64, limit_m=6.01)
    assert share == pytest.approx(20 / 9500) and share > CUT_OFF_FRACTION
    assert "lie at the largest disparity searched, 64 px: surfaces nearer than 6.01 m are cut off" in caplog.text
    # the advice: a maximum of 64 px on a map 100 px wide already searches beyond the default 33 px
    assert caplog.text.rstrip().endswith("raise the maximum disparity (--max-disparity)")
    caplog.clear()
    with caplog.at_level("WARNING", logger="stereo_obstacles.matching"):
        warn_if_range_cut_off(np.where(d > 63, np.float32(19.7), d), 20)   # below the default: unset searches more
    assert "raise the maximum disparity (--max-disparity) or leave it unset" in caplog.text
    caplog.clear()
    with caplog.at_level("WARNING", logger="stereo_obstacles.matching"):
        warn_if_range_cut_off(d, 64, default_limit=True)     # no maximum was given: it cannot be left unset
    assert "the default limit is a third of the image width: give a larger --max-disparity" in caplog.text
    assert "leave it unset" not in caplog.text
    caplog.clear()
    d[1, 10:20] = 63.4                               # below the half pixel: 10 left, 0.11 %
    with caplog.at_level("WARNING", logger="stereo_obstacles.matching"):
        assert warn_if_range_cut_off(d, 64) == pytest.approx(10 / 9500)
    assert caplog.text == ""
    assert warn_if_range_cut_off(np.full((4, 4), np.inf, np.float32), 64) == 0.0    # PFM's "none": no match


def test_a_disparity_command_with_a_range_too_short_says_so(tmp_path, caplog):
    from stereo_obstacles.cli import main
    from stereo_obstacles.fileio import write_image
    from stereo_obstacles.synthetic import default_scene, render_pair

    pair = render_pair(default_scene(320, 240))
    write_image(tmp_path / "l.png", pair.left)
    write_image(tmp_path / "r.png", pair.right)
    with caplog.at_level("WARNING"):
        assert main(["disparity", str(tmp_path / "l.png"), str(tmp_path / "r.png"), "-o", str(tmp_path / "d.npy"),
                     "--max-disparity", "8"]) == 0
    assert "lie at the largest disparity searched, 8 px" in caplog.text and "raise the maximum" in caplog.text
    caplog.clear()
    with caplog.at_level("WARNING"):
        assert main(["disparity", str(tmp_path / "l.png"), str(tmp_path / "r.png"), "-o", str(tmp_path / "d.npy")]) == 0
    assert "largest disparity searched" not in caplog.text
    write_image(tmp_path / "l.png", np.ascontiguousarray(pair.left[:, 30:60]))    # 30 px wide: 10 px by default
    write_image(tmp_path / "r.png", np.ascontiguousarray(pair.right[:, 30:60]))
    with caplog.at_level("WARNING"):
        assert main(["disparity", str(tmp_path / "l.png"), str(tmp_path / "r.png"), "-o", str(tmp_path / "d.npy")]) == 0
    assert "largest disparity searched, 10 px" in caplog.text and "the default limit is a third" in caplog.text


def test_float_images_of_0_to_1_match_like_their_8_bit_originals():
    from stereo_obstacles.similarity import grey_pair, to_grey
    from stereo_obstacles.synthetic import default_scene, render_pair

    pair = render_pair(default_scene(160, 120))
    unit = pair.left / 255.0, pair.right / 255.0
    assert grey_pair(*unit)[1] == pytest.approx(to_grey(pair.right), abs=1e-3)
    as_bytes = match(pair.left, pair.right)
    as_unit_floats = match(*unit)                                           # matched nothing before
    assert as_unit_floats.stats.density == pytest.approx(as_bytes.stats.density, abs=0.01)
    assert as_bytes.stats.density > 0.5
    overshoot = unit[1].copy()
    overshoot[0, 0, 0] = 1.02                 # one value above 1: the pair keeps its own units, both images
    assert max(g.max() for g in grey_pair(unit[0], overshoot)) < 1.1
    assert to_grey(np.full((4, 4), 0.5)).max() == 0.5                       # a single image is never rescaled


def test_match_options_are_checked_without_images():
    from stereo_obstacles.matching import check_match_options

    check_match_options()
    check_match_options(tau=0.6, max_disparity=40, seeds="canny")
    with pytest.raises(InvalidInputError, match="not options of the matcher: left, taux"):
        check_match_options(taux=0.6, left=None)
    with pytest.raises(InvalidInputError, match="max_disparity: expected an integer >= min_disparity"):
        check_match_options(min_disparity=10, max_disparity=5)
