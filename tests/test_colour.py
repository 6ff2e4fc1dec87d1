"""HSI conversion against hand-computed values, validity masks, errors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from stereo_obstacles.colour import HSI, hue_difference, rgb_to_hsi
from stereo_obstacles.errors import InvalidInputError


def _reference_hsi(r: float, g: float, b: float) -> tuple[float, float, float]:
    """Textbook HSI (Gonzalez & Woods, arccos form) of one pixel in [0, 1] units."""
    i = (r + g + b) / 3.0
    s = 1.0 - min(r, g, b) / i
    num = 0.5 * ((r - g) + (r - b))
    den = math.sqrt((r - g) ** 2 + (r - b) * (g - b))
    theta = math.degrees(math.acos(max(-1.0, min(1.0, num / den))))
    return (theta if b <= g else 360.0 - theta), s, i


@pytest.mark.parametrize("rgb, hue, saturation, intensity", [
    ((200, 100, 50), 19.1066, 4.0 / 7.0, 350.0 / 765.0),   # theta = acos(125 / sqrt(17500))
    ((255, 0, 0), 0.0, 1.0, 1.0 / 3.0),
    ((0, 255, 0), 120.0, 1.0, 1.0 / 3.0),
    ((0, 0, 255), 240.0, 1.0, 1.0 / 3.0),
    ((255, 255, 0), 60.0, 1.0, 2.0 / 3.0),
    ((0, 255, 255), 180.0, 1.0, 2.0 / 3.0),
    ((255, 0, 255), 300.0, 1.0, 2.0 / 3.0),
    ((100, 50, 200), 259.1066, 4.0 / 7.0, 350.0 / 765.0),  # 360 - acos(-25 / sqrt(17500))
])
def test_hand_computed_values(rgb, hue, saturation, intensity):
    hsi = rgb_to_hsi(np.array([[rgb]], dtype=np.uint8), min_intensity=0.0, min_saturation=0.0)
    assert hsi.hue[0, 0] == pytest.approx(hue, abs=1e-3)
    assert hsi.saturation[0, 0] == pytest.approx(saturation, abs=1e-5)
    assert hsi.intensity[0, 0] == pytest.approx(intensity, abs=1e-6)


def test_matches_textbook_formula_on_random_pixels():
    rng = np.random.default_rng(1)
    rgb = rng.integers(0, 256, size=(20, 20, 3), dtype=np.uint8)
    hsi = rgb_to_hsi(rgb, min_intensity=0.0, min_saturation=0.02)
    for y, x in np.ndindex(20, 20):
        r, g, b = (float(v) / 255.0 for v in rgb[y, x])
        if len({r, g, b}) == 1:
            continue
        h, s, i = _reference_hsi(r, g, b)
        assert hsi.intensity[y, x] == pytest.approx(i, abs=1e-6)
        assert hsi.saturation[y, x] == pytest.approx(s, abs=1e-5)
        if s >= 0.02:
            assert abs(hue_difference(hsi.hue[y, x], h)) < 1e-2


def test_validity_masks_follow_thresholds():
    rgb = np.array([[[10, 5, 5], [128, 128, 128], [130, 110, 110], [200, 40, 40]]], dtype=np.uint8)
    hsi = rgb_to_hsi(rgb, min_intensity=0.05, min_saturation=0.05)
    # dark: nothing valid; grey: saturation only; weakly coloured (S = 0.057): hue too; red: both
    assert hsi.saturation_valid.tolist() == [[False, True, True, True]]
    assert hsi.hue_valid.tolist() == [[False, False, True, True]]
    assert np.isnan(hsi.hue[0, 0]) and np.isnan(hsi.saturation[0, 0])
    assert hsi.intensity[0, 0] == pytest.approx(20.0 / 765.0)


def test_uint16_uses_its_own_full_scale():
    eight = rgb_to_hsi(np.array([[[200, 100, 50]]], dtype=np.uint8))
    sixteen = rgb_to_hsi(np.array([[[200 * 257, 100 * 257, 50 * 257]]], dtype=np.uint16))
    assert sixteen.intensity[0, 0] == pytest.approx(eight.intensity[0, 0], abs=1e-6)
    assert sixteen.hue[0, 0] == pytest.approx(eight.hue[0, 0], abs=1e-3)


def test_output_types_and_hue_range():
    rng = np.random.default_rng(2)
    hsi = rgb_to_hsi(rng.integers(0, 256, size=(31, 17, 3), dtype=np.uint8))
    assert isinstance(hsi, HSI)
    for a in (hsi.hue, hsi.saturation, hsi.intensity):
        assert a.dtype == np.float32 and a.shape == (31, 17)
    h = hsi.hue[hsi.hue_valid]
    assert h.size > 0 and h.min() >= 0.0 and h.max() < 360.0


@pytest.mark.parametrize("bad, match", [
    (np.zeros((4, 4), np.uint8), "shape"),
    (np.zeros((4, 4, 4), np.uint8), "shape"),
    (np.zeros((4, 4, 3), np.float32), "uint8 or uint16"),
])
def test_rejects_bad_images(bad, match):
    with pytest.raises(InvalidInputError, match=match):
        rgb_to_hsi(bad)


def test_rejects_bad_thresholds():
    with pytest.raises(InvalidInputError, match="min_saturation"):
        rgb_to_hsi(np.zeros((2, 2, 3), np.uint8), min_saturation=1.5)


def test_hue_difference_wraps():
    assert hue_difference(350.0, 10.0) == pytest.approx(-20.0)
    assert hue_difference(10.0, 350.0) == pytest.approx(20.0)
    assert hue_difference(180.0, 0.0) == pytest.approx(-180.0)
    assert np.isnan(hue_difference(np.nan, 0.0))
