"""Reference rectangle parsing and robust ground statistics."""

from __future__ import annotations

import logging
import math

import numpy as np
import pytest

from stereo_obstacles.colour import rgb_to_hsi
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.reference_area import (DEFAULT_REFERENCE_AREA, ReferenceArea,
                                             ReferenceParameters, ReferenceStatistics,
                                             circular_median_deg, reference_statistics)
from stereo_obstacles.segmentation import segment


def _noisy(colour, shape=(40, 60), sigma=3.0, seed=0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.clip(rng.normal(colour, sigma, shape + (3,)), 0, 255).astype(np.uint8)


def _stats(rgb, **kwargs) -> ReferenceStatistics:
    return reference_statistics(rgb, rgb_to_hsi(rgb), (0, 0, rgb.shape[1], rgb.shape[0]), **kwargs)


def test_parse_fractions_and_pixels():
    assert DEFAULT_REFERENCE_AREA.unit == "fraction"
    area = ReferenceArea.parse("0.25,0.8,0.75,1")
    assert area == ReferenceArea(0.25, 0.8, 0.75, 1.0, unit="fraction")
    assert area.to_pixels(100, 200) == (50, 80, 150, 100)
    px = ReferenceArea.parse("10,20,50,60")
    assert px.unit == "px" and px.to_pixels(40, 30) == (10, 20, 30, 40)


@pytest.mark.parametrize("text", ["1,2,3", "a,b,c,d", "0.5,0.5,0.4,0.9", "-1,0,5,5"])
def test_parse_rejects(text):
    with pytest.raises(InvalidInputError, match="reference"):
        ReferenceArea.parse(text)


def test_fractions_mixed_with_pixels_are_refused_not_read_as_pixels():
    with pytest.raises(InvalidInputError, match="mixes fractions of the image .* and pixels"):
        ReferenceArea.parse("0,0.85,1,1.5")                 # meant 0,0.85,1,1: would be a 1x2 px area
    assert ReferenceArea.parse("0,300,640,480").unit == "px"
    with pytest.raises(InvalidInputError, match="corners in pixels must be whole numbers"):
        ReferenceArea.parse("10.5,20,100,200")


def test_area_outside_image_is_an_error_naming_its_corners_and_unit():
    with pytest.raises(InvalidInputError, match=r"reference area 100,100,120,120 \(pixels\) is empty"):
        ReferenceArea(100, 100, 120, 120, unit="px").to_pixels(50, 50)


def test_an_area_in_pixels_reaching_past_the_image_is_cut_to_it_and_said_so(caplog):
    # --reference 0,0,2000,2000 on a 640x480 pair was cut to the image without a word (review, session 24)
    with caplog.at_level("WARNING", logger="stereo_obstacles.reference_area"):
        assert ReferenceArea(0, 400, 2000, 2000, unit="px").to_pixels(480, 640) == (0, 400, 640, 480)
    assert "reference area 0,400,2000,2000 (pixels) reaches past the 640x480 image: (0, 400, 640, 480) is used" \
        in caplog.text
    caplog.clear()
    with caplog.at_level("WARNING", logger="stereo_obstacles.reference_area"):
        assert ReferenceArea(0, 400, 640, 480, unit="px").to_pixels(480, 640) == (0, 400, 640, 480)
        assert ReferenceArea(0.0, 0.85, 1.0, 1.0).to_pixels(480, 640) == (0, 408, 640, 480)
    assert caplog.text == ""


def test_area_smaller_than_the_pixels_it_needs_says_so():
    rgb = _noisy((120, 140, 90))[:4, :4]                     # 16 pixels, each bright enough
    with pytest.raises(InvalidInputError, match="holds only 16 pixels; it needs at least 30"):
        _stats(rgb)


def test_circular_median_across_wrap():
    assert circular_median_deg(np.array([350.0, 355.0, 2.0, 8.0, 359.0])) == pytest.approx(359.0)
    assert circular_median_deg(np.array([10.0, 20.0, 30.0])) == pytest.approx(20.0)


def test_statistics_of_uniform_coloured_ground():
    s = _stats(_noisy((90, 140, 60)))
    assert not s.is_grey
    assert abs(((s.hue_deg - 98.3) + 180) % 360 - 180) < 2.0
    assert s.intensity_low < s.intensity_median < s.intensity_high
    assert s.intensity_median == pytest.approx(290 / 765, abs=0.01)
    assert 4.0 <= s.hue_threshold_deg <= 45.0


def test_robust_to_a_shadow_and_an_object_inside():
    clean = _stats(_noisy((90, 140, 60)))
    rgb = _noisy((90, 140, 60))
    rgb[:12, :20] = (rgb[:12, :20] * 0.5).astype(np.uint8)     # 10 % shadow
    rgb[25:35, 40:55] = (200, 30, 200)                          # 6 % magenta object
    s = _stats(rgb)
    assert s.intensity_median == pytest.approx(clean.intensity_median, abs=0.01)
    assert s.intensity_low > 0.8 * clean.intensity_low         # the shadow is not in the range
    assert abs(((s.hue_deg - clean.hue_deg) + 180) % 360 - 180) < 1.0
    assert s.n_kept < 0.9 * s.n_pixels


def test_grey_ground_uses_saturation():
    s = _stats(_noisy((120, 120, 122)))
    assert s.is_grey and s.hue_deg is None
    assert 0.0 < s.max_saturation < 0.2


def test_too_dark_area_is_an_error():
    with pytest.raises(InvalidInputError, match="unusable.*bright enough"):
        _stats(_noisy((5, 5, 5), sigma=1.0))


def test_area_of_two_hue_clusters_and_mostly_grey_is_an_error():
    """The pixels with a hue split into two clusters far apart and the hue-less ones are most of
    the area: no pixel is kept (once a NumPy-free median crashed here)."""
    pixels = [(5, 5, 5)] * 30 + [(120, 120, 120)] * 26 + [(200, 60, 60)] * 22 + [(200, 130, 60)] * 22
    image = np.full((60, 10, 3), 100, np.uint8)
    image[50:] = np.array(pixels, np.uint8).reshape(10, 10, 3)
    for right in (None, image):
        with pytest.raises(InvalidInputError, match="unusable: no pixel is consistent with one ground"):
            segment(image, right=right, reference=ReferenceArea(0, 50, 10, 60, unit="px"))


def test_varied_area_warns(caplog):
    rgb = _noisy((90, 140, 60))
    rgb[:, 20:40] = _noisy((40, 60, 160), shape=(40, 20))     # a third blue, a third red
    rgb[:, 40:] = _noisy((160, 40, 40), shape=(40, 20))
    with caplog.at_level(logging.WARNING, logger="stereo_obstacles.reference_area"):
        _stats(rgb)
    assert "look like one ground" in caplog.text or "very varied" in caplog.text


def test_parameters_are_validated():
    with pytest.raises(InvalidInputError, match="min_hue_fraction"):
        ReferenceParameters(min_hue_fraction=2.0)
    with pytest.raises(InvalidInputError, match="max_hue_threshold_deg"):
        ReferenceParameters(min_hue_threshold_deg=50.0, max_hue_threshold_deg=10.0)
    with pytest.raises(InvalidInputError, match="max_samples"):
        ReferenceParameters(max_samples=0)
    for field, bad in (("outlier_mads", "3"), ("spread_percentile", 50.0), ("min_outlier_hue_deg", None),
                       ("min_pixels", 10.0), ("warn_kept_fraction", float("nan"))):
        with pytest.raises(InvalidInputError, match=field):
            ReferenceParameters(**{field: bad})


def test_grey_ground_rejects_a_coloured_object_inside():
    rgb = _noisy((120, 120, 122))
    rgb[:, :18] = _noisy((170, 40, 50), shape=(40, 18))      # 30 % of the area is a red object
    s = _stats(rgb)
    assert s.is_grey and s.max_saturation < 0.2
    assert s.rgb_median[0] == pytest.approx(120 / 255, abs=0.02)
    assert s.n_kept < 0.75 * s.n_pixels


def test_sample_step_keeps_at_most_max_samples():
    params = ReferenceParameters(max_samples=1000)
    for height, width in ((1, 1), (10, 100), (31, 33), (72, 640), (56, 1242)):
        step = params.sample_step(height, width)
        assert math.ceil(height / step) * math.ceil(width / step) <= 1000
        if step > 1:
            assert math.ceil(height / (step - 1)) * math.ceil(width / (step - 1)) > 1000
