"""The ground colour model: table against a slow reference, and constructed shadow cases."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from stereo_obstacles._ground_colour_kernel import NEAR_BIT, fill_table_kernel, ground_cells_kernel
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.ground_colour import (GROUND_BIT, SHADOW_BIT, SUNLIT_BIT, GroundColourParameters,
                                            build_ground_colour_model, colour_flags, shadow_shifts)
from stereo_obstacles.labels import Label
from stereo_obstacles.segmentation import SegmentationParameters, segment

SKYLIGHT = np.array((0.57, 0.625, 0.71))
"""Gamma-space attenuation of a cast shadow in the synthetic world (sun at 40 degrees)."""


def _u8(image: np.ndarray) -> np.ndarray:
    return np.clip(np.rint(image), 0, 255).astype(np.uint8)


def _two_colour_tiles(shape=(120, 168), seed=1) -> np.ndarray:
    """Pavers 8 px square alternating red-brown and grey-brown, with noise."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:shape[0], 0:shape[1]]
    second = ((yy // 8 + xx // 8) % 2).astype(bool)
    image = np.where(second[..., None], (150, 118, 105), (170, 80, 60)).astype(float)
    return image + rng.normal(0, 2.5, image.shape)


def _slow_table(rgb, box, params, shadow_ratio):
    """The table from its definition, with Python loops."""
    model = build_ground_colour_model(rgb, box, params=params, shadow_ratio=shadow_ratio)
    lut, n = model.lut, model.table.shape[0]
    x0, y0, x1, y1 = box
    edges = np.linspace(x0, x1, params.n_strips + 1).round().astype(int)
    import cv2
    per_strip = []
    for a, b in zip(edges[:-1], edges[1:]):
        counts: dict = {}
        for k in params.texture_scales_px:
            area = rgb[y0:y1, a:b] if k == 1 else cv2.blur(rgb[y0:y1, a:b], (k, k), borderType=cv2.BORDER_REFLECT)
            for pixel in area.reshape(-1, 3):
                cell = tuple(int(lut[v]) for v in pixel)
                counts[cell] = counts.get(cell, 0) + 1
        per_strip.append(counts)
    expected = np.zeros((n, n, n), np.uint8)
    cells = set().union(*per_strip)
    for cell in cells:
        if sum(c.get(cell, 0) >= params.min_count for c in per_strip) < params.quorum:
            continue
        for dr, dg, db, bit in model.shifts:
            target = (cell[0] + dr, cell[1] + dg, cell[2] + db)
            if all(0 <= t < n for t in target):
                expected[target] |= bit
    set_cells = np.argwhere(expected != 0)
    near = np.zeros_like(expected, dtype=bool)
    for r, g, b in set_cells:
        near[max(r - 1, 0):r + 2, max(g - 1, 0):g + 2, max(b - 1, 0):b + 2] = True
    expected[near] |= 8
    return model.table, expected


@pytest.mark.parametrize("chroma_radius", [1, None])
@pytest.mark.parametrize("shadow_ratio", [(0.4, 0.8), None])
def test_table_matches_its_definition(shadow_ratio, chroma_radius):
    rgb = _u8(_two_colour_tiles((40, 42)))
    rgb[30:, 5:12] = (20, 160, 30)                       # an object in one strip only
    rgb[:12] = _u8(rgb[:12] * SKYLIGHT)                  # a cast shadow beyond the area
    params = GroundColourParameters(n_strips=3, quorum=2, shift_chroma_radius_bins=chroma_radius)
    table, expected = _slow_table(rgb, (0, 30, 42, 40), params, shadow_ratio)
    np.testing.assert_array_equal(table, expected)
    assert np.count_nonzero(table & GROUND_BIT) > 0
    assert bool(np.any(table & SHADOW_BIT)) == (shadow_ratio is not None)
    assert bool(np.any(table & SUNLIT_BIT)) == (shadow_ratio is not None)


def test_shifts_are_darker_and_bluer():
    shifts = shadow_shifts(GroundColourParameters(), (0.4, 0.8))
    shadow = shifts[shifts[:, 3] == SHADOW_BIT, :3]
    assert np.all(shadow[:, 1] < 0)                      # darker
    assert np.all(shadow[:, 0] < shadow[:, 2])           # red falls more than blue
    sunlit = shifts[shifts[:, 3] == SUNLIT_BIT, :3]
    np.testing.assert_array_equal(np.sort(-sunlit, axis=0), np.sort(shadow, axis=0))


def test_shadow_on_two_colour_tiles_is_ground():
    image = _two_colour_tiles()
    region = np.s_[20:70, 30:130]
    image[region] *= SKYLIGHT
    labels = segment(_u8(image)).labels
    assert np.mean(labels[region] == Label.SHADOW) > 0.95
    assert np.mean(labels[80:, :] == Label.GROUND) > 0.95
    off = segment(_u8(image), params=SegmentationParameters(shadow_rule=False)).labels
    assert np.mean(off[region] == Label.OBSTACLE) > 0.95


@pytest.mark.xfail(strict=True, reason="known weakness: a uniformly darkened paver colour falls on cells "
                   "set by the skylight shifts that move blue against red by only 3 cells "
                   "(min_shadow_chroma_bins=4 fixes it but costs real shadows; docs/segmentation.md). "
                   "Colour alone; with the right image the stereo ground check finds it "
                   "(tests/test_ground_check.py)")
def test_dark_obstacle_of_ground_colour_on_tiles_is_an_obstacle():
    image = _two_colour_tiles()
    region = np.s_[20:60, 60:100]
    image[region] *= 0.62                                # same colours, as dark as a shadow
    labels = segment(_u8(image)).labels
    assert np.mean(labels[region] == Label.OBSTACLE) > 0.95


def test_grey_ground_shadow_and_grey_obstacle():
    rng = np.random.default_rng(2)
    image = rng.normal((118, 118, 122), 3, (120, 160, 3))
    shadow, box = np.s_[10:50, 10:70], np.s_[10:50, 100:140]
    image[shadow] *= SKYLIGHT
    image[box] = rng.normal((175, 175, 178), 3, (40, 40, 3))   # lighter grey object
    labels = segment(_u8(image)).labels
    assert np.mean(labels[shadow] == Label.SHADOW) > 0.95
    assert np.mean(labels[box] == Label.OBSTACLE) > 0.95


def test_obstacle_in_part_of_the_reference_area_is_not_ground():
    image = _two_colour_tiles()
    image[70:, 10:40] = (40, 70, 170)                    # a blue box standing in the area
    labels = segment(_u8(image)).labels
    assert np.mean(labels[75:, 15:35] == Label.OBSTACLE) > 0.95
    assert np.mean(labels[:60, :] == Label.GROUND) > 0.95


def test_flags_need_the_model_bit_depth():
    rgb = _u8(_two_colour_tiles((40, 42)))
    model = build_ground_colour_model(rgb, (0, 30, 42, 40))
    with pytest.raises(InvalidInputError, match="bit depth"):
        colour_flags(rgb.astype(np.uint16), model, 0.05)
    flags, veto = colour_flags(rgb, model, 0.05)
    assert flags.shape == (40, 42, 4) and flags.dtype == np.uint8 and veto.dtype == bool


@pytest.mark.parametrize("kwargs, match", [
    ({"bin": 0.0}, "bin"), ({"quorum": 9}, "quorum"), ({"texture_scales_px": (0,)}, "texture"),
    ({"min_blueness": 0.8, "max_blueness": 0.5}, "blueness"), ({"green_tolerance_bins": -1}, "green"),
    ({"min_shadow_chroma_bins": -1}, "min_shadow_chroma"), ({"min_shadow_chroma_bins": True}, "min_shadow_chroma"),
])
def test_parameters_are_validated(kwargs, match):
    with pytest.raises(InvalidInputError, match=match):
        GroundColourParameters(**kwargs)


def test_narrow_area_and_bad_ratio_are_rejected():
    rgb = _u8(_two_colour_tiles((40, 42)))
    with pytest.raises(InvalidInputError, match="wide"):
        build_ground_colour_model(rgb, (0, 30, 4, 40))
    with pytest.raises(InvalidInputError, match="shadow_ratio"):
        shadow_shifts(GroundColourParameters(), (0.8, 0.4))


def test_every_cell_bit_combination_is_read_back():
    rgb = np.array([[[v, v, v] for v in range(0, 256, 16)]], dtype=np.uint8)
    model = build_ground_colour_model(np.repeat(rgb, 8, axis=0), (0, 0, 16, 8),
                                      params=GroundColourParameters(n_strips=1, quorum=1, min_count=1))
    flags, veto = colour_flags(rgb, model, 0.0)
    for x, (r, g, b) in enumerate(rgb[0]):
        cell = int(model.table[model.lut[r], model.lut[g], model.lut[b]])
        assert [int(v) for v in flags[0, x, :3]] == [cell & 1, (cell >> 1) & 1, (cell >> 2) & 1]
        assert veto[0, x] == (cell & 8 == 0)
    assert list(itertools.islice(flags[0, :, 3], 1)) == [1]


def test_only_the_images_own_shadow_shift_is_kept():
    full = shadow_shifts(GroundColourParameters(), (0.4, 0.8))
    ground = _u8(np.random.default_rng(3).normal((90, 140, 60), 3, (120, 160, 3)))
    ground[10:40] = _u8(ground[10:40] * SKYLIGHT)        # the real shadow: one shift
    model = build_ground_colour_model(ground, (0, 100, 160, 120), params=GroundColourParameters(shift_chroma_radius_bins=2))
    kept = {tuple(row) for row in model.shifts.tolist()}
    assert kept < {tuple(row) for row in full.tolist()} and len(kept) < len(full) // 3
    # the real shadow stays shadow ...
    flags, _ = colour_flags(ground, model, 0.05)
    assert flags[15:35, :, 1].mean() > 0.8
    # ... while the ground under another light of the family (darker, much bluer) is dropped
    other = _u8(np.random.default_rng(4).normal((90, 140, 60), 3, (20, 20, 3)) * (0.34, 0.45, 0.595))
    wide = build_ground_colour_model(ground, (0, 100, 160, 120))                 # the default: every shift
    assert colour_flags(other, wide, 0.05)[0][..., 1].mean() > colour_flags(other, model, 0.05)[0][..., 1].mean() + 0.3


@pytest.mark.parametrize("min_chroma", [0, 2, 4])
def test_min_shadow_chroma_drops_only_the_greyish_shifts(min_chroma):
    full = shadow_shifts(GroundColourParameters(), (0.4, 0.8))
    kept = shadow_shifts(GroundColourParameters(min_shadow_chroma_bins=min_chroma), (0.4, 0.8))
    shadow = kept[kept[:, 3] == SHADOW_BIT, :3]
    assert np.all(shadow[:, 2] - shadow[:, 0] >= min_chroma)
    expected = {tuple(r) for r in full.tolist() if r[3] == GROUND_BIT
                or abs(r[2] - r[0]) >= min_chroma}
    assert {tuple(r) for r in kept.tolist()} == expected
    assert (len(kept) < len(full)) == (min_chroma > 1)   # the weakest skylight shift moves red vs blue 1 cell


def test_weakly_darkened_obstacle_of_ground_colour_with_min_shadow_chroma():
    rng = np.random.default_rng(3)
    image = rng.normal((150, 118, 105), 2.5, (120, 168, 3))
    obstacle, shadow, weak = np.s_[15:55, 100:150], np.s_[15:55, 10:70], np.s_[62:78, 10:150]
    image[obstacle] *= 0.8                               # grey darkening, k = 0
    image[shadow] *= SKYLIGHT
    u, k = np.log(0.8), 0.55                             # the weakest skylight shadow of the family
    image[weak] *= np.exp([u * (1 + k / 2), u, u * (1 - k / 2)])
    option = SegmentationParameters(ground_colour=GroundColourParameters(min_shadow_chroma_bins=2))
    labels = segment(_u8(image), params=option).labels
    assert np.mean(labels[obstacle] == Label.OBSTACLE) > 0.95
    assert np.mean(labels[shadow] == Label.SHADOW) > 0.95
    assert np.mean(labels[weak] == Label.SHADOW) > 0.95
    assert np.mean(labels[90:] == Label.GROUND) > 0.95
    default = segment(_u8(image)).labels                 # the whole family calls it a shadow
    assert np.mean(default[obstacle] == Label.SHADOW) > 0.9


@pytest.mark.parametrize("seed", range(3))
def test_colour_table_matches_its_definition(seed):
    """Every ground cell moved by every shift gets that shift's bits; every cell within one bin
    of a set cell (the 3 x 3 x 3 cube, clipped at the table's edges) gets ``NEAR_BIT``."""
    rng = np.random.default_rng(seed)
    n_bins = 12
    ground = rng.choice(n_bins ** 3, size=15, replace=False).astype(np.int64)
    shifts = np.column_stack([rng.integers(-3, 4, (20, 3)), rng.choice([0, GROUND_BIT, SHADOW_BIT, SUNLIT_BIT], 20)])
    table = np.zeros((n_bins,) * 3, dtype=np.uint8)
    fill_table_kernel(ground, n_bins, shifts.astype(np.int32), table)   # the dtype of shadow_shifts
    want = np.zeros((n_bins,) * 3, dtype=np.uint8)
    for r, g, b in zip(*np.unravel_index(ground, want.shape)):
        for dr, dg, db, bits in shifts:
            if all(0 <= v < n_bins for v in (r + dr, g + dg, b + db)):
                want[r + dr, g + dg, b + db] |= bits
    padded = np.pad(want != 0, 1)
    near = np.zeros(want.shape, dtype=bool)
    for dr, dg, db in itertools.product(range(3), repeat=3):
        near |= padded[dr:dr + n_bins, dg:dg + n_bins, db:db + n_bins]
    want[near] |= NEAR_BIT
    np.testing.assert_array_equal(table, want)
    assert (table & NEAR_BIT).any() and not (table & NEAR_BIT).all()


@pytest.mark.parametrize("seed", range(3))
def test_ground_cells_match_their_definition(seed):
    """A cell is ground when at least ``quorum`` strips hold at least ``min_count`` samples in it,
    whatever the texture scale of the samples."""
    rng = np.random.default_rng(seed)
    n_bins, n_strips, quorum, min_count = 4, 5, 3, 2
    lut = rng.integers(0, n_bins, 256).astype(np.int32)              # the dtype of the model's lookup table
    samples = rng.integers(0, 256, (2, 6, 20, 3)).astype(np.uint8)
    samples[:, :, :, 0] = rng.choice([10, 200], samples.shape[:3])   # few red cells: some cells repeat
    column_strip = np.repeat(np.arange(n_strips, dtype=np.int32), 4)
    cells = ground_cells_kernel(samples, lut, column_strip, n_strips, quorum, min_count, n_bins)
    flat = (lut[samples[..., 0]] * n_bins + lut[samples[..., 1]]) * n_bins + lut[samples[..., 2]]
    counts = np.zeros((n_bins ** 3, n_strips), dtype=int)
    np.add.at(counts, (flat, np.broadcast_to(column_strip, flat.shape)), 1)
    want = np.flatnonzero((counts >= min_count).sum(axis=1) >= quorum)
    np.testing.assert_array_equal(np.sort(cells), want)
    assert 0 < want.size < np.unique(flat).size
