"""The phase-1 classifier on constructed scenes: shadow, dark object of ground hue, grey ground."""

from __future__ import annotations

import numpy as np
import pytest

from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.labels import Label
from stereo_obstacles.reference_area import ReferenceArea
from stereo_obstacles.segmentation import SegmentationParameters, SegmentationResult, segment

GREEN = np.array((90, 140, 60), dtype=float)
ASPHALT = np.array((118, 118, 122), dtype=float)


def _ground(colour, shape=(120, 160), sigma=3.0, seed=0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.normal(colour, sigma, shape + (3,))


def _u8(image: np.ndarray) -> np.ndarray:
    return np.clip(np.rint(image), 0, 255).astype(np.uint8)


def _fraction(labels: np.ndarray, region, label: Label) -> float:
    return float(np.mean(labels[region] == label))


SKYLIGHT = np.array((0.57, 0.625, 0.71))
"""Per-channel attenuation of a cast shadow lit by the blue sky alone (darker and bluer): the
synthetic world's sun and sky at 40 degrees elevation, after the display gamma."""


def test_shadow_is_ground_in_shadow_and_an_obstacle_without_the_rule():
    image = _ground(GREEN)
    region = np.s_[30:70, 20:100]
    image[region] *= SKYLIGHT
    rgb = _u8(image)
    on = segment(rgb).labels
    assert _fraction(on, region, Label.SHADOW) > 0.98
    assert _fraction(on, np.s_[80:, :], Label.GROUND) > 0.98
    off = segment(rgb, params=SegmentationParameters(shadow_rule=False)).labels
    assert _fraction(off, region, Label.OBSTACLE) > 0.98


def test_reference_in_shadow_sunlit_ground_is_ground():
    image = _ground(GREEN)
    image[60:, :] *= SKYLIGHT                             # the tree's shadow covers the reference
    labels = segment(_u8(image)).labels
    assert _fraction(labels, np.s_[:55, :], Label.GROUND) > 0.98
    assert _fraction(labels, np.s_[65:, :], Label.GROUND) > 0.98


def test_dark_obstacle_of_ground_hue_is_not_a_shadow():
    image = _ground(GREEN)
    region = np.s_[30:70, 60:90]
    image[region] *= 0.45                                # same hue and as dark as a shadow,
    labels = segment(_u8(image)).labels                  # but lit by the sun: not bluer
    assert _fraction(labels, region, Label.OBSTACLE) > 0.95
    image[region] *= 0.1 / 0.45                          # far darker than any shadow
    labels = segment(_u8(image)).labels
    assert _fraction(labels, region, Label.OBSTACLE) > 0.95


def test_coloured_and_grey_obstacles_on_coloured_ground():
    image = _ground(GREEN)
    image[20:50, 20:50] = (200, 40, 40)                  # red box
    image[20:50, 100:130] = (128, 128, 128)              # grey box, ground-like brightness
    labels = segment(_u8(image)).labels
    assert _fraction(labels, np.s_[20:50, 20:50], Label.OBSTACLE) > 0.98
    assert _fraction(labels, np.s_[20:50, 100:130], Label.OBSTACLE) > 0.98


def test_grey_ground_with_shadow_and_obstacle():
    image = _ground(ASPHALT)
    image[10:40, 20:60] *= SKYLIGHT                      # shadow on asphalt
    image[10:40, 100:140] = (60, 90, 200)                # blue bin
    image[50:70, 100:140] = (230, 230, 230)              # white object: too bright for ground
    rgb = _u8(image)
    result = segment(rgb)
    assert result.reference.is_grey
    labels = result.labels
    assert _fraction(labels, np.s_[10:40, 20:60], Label.SHADOW) > 0.95
    assert _fraction(labels, np.s_[10:40, 100:140], Label.OBSTACLE) > 0.98
    assert _fraction(labels, np.s_[50:70, 100:140], Label.OBSTACLE) > 0.98
    assert _fraction(labels, np.s_[80:, :], Label.GROUND) > 0.98


def test_thin_pole_survives_and_specks_and_holes_are_cleaned():
    image = _ground(GREEN)
    image[10:90, 40:43] = (40, 40, 160)                  # 3 px wide pole: other hue, darker
    image[50:52, 120:122] = (200, 40, 40)                # 2x2 speck: removed
    image[15:45, 90:120] = (200, 40, 40)                 # box with a 2x2 hole of ground colour
    image[30:32, 104:106] = GREEN
    labels = segment(_u8(image)).labels
    assert _fraction(labels, np.s_[10:90, 40:43], Label.OBSTACLE) > 0.9
    assert not np.any(labels[50:52, 120:122] == Label.OBSTACLE)
    assert np.all(labels[30:32, 104:106] == Label.OBSTACLE)


def test_result_types_and_reference_record():
    rgb = _u8(_ground(GREEN))
    result = segment(rgb, reference=ReferenceArea(50, 100, 110, 120, unit="px"))
    assert isinstance(result, SegmentationResult)
    assert result.labels.dtype == np.uint8 and result.labels.shape == rgb.shape[:2]
    assert result.reference.box_px == (50, 100, 110, 120)
    assert set(np.unique(result.labels)) <= {Label.UNKNOWN, Label.GROUND, Label.SHADOW, Label.OBSTACLE}
    assert result.ground_mask.mean() > 0.98 and not result.obstacle_mask.any()


def test_uint16_input_gives_the_same_labels():
    rgb = _u8(_ground(GREEN))
    rgb[20:50, 20:50] = (200, 40, 40)
    eight = segment(rgb).labels
    sixteen = segment(rgb.astype(np.uint16) * 257).labels
    np.testing.assert_array_equal(eight, sixteen)


def test_unusable_reference_is_an_error(caplog):
    rgb = _u8(_ground(GREEN))
    rgb[100:, :] = 3                                     # black bottom: nothing to measure
    with pytest.raises(InvalidInputError, match="reference area .* unusable"):
        segment(rgb)
    with pytest.raises(InvalidInputError, match="reference area .* unusable"):
        segment(rgb, right=rgb)                          # no warning of the stereo check before the error
    assert "stereo ground check" not in caplog.text and "ground plane" not in caplog.text


@pytest.mark.parametrize("kwargs, match", [
    ({"shadow_min_ratio": 0.9, "shadow_max_ratio": 0.5}, "shadow_min_ratio"),
    ({"shadow_max_ratio": 1.2}, "shadow_max_ratio"),
    ({"filter_size": 6}, "odd"),
    ({"shadow_rule": 1}, "bool"),
    ({"min_obstacle_area_px": -1}, "min_obstacle_area_px"),
    ({"max_hole_fraction": 1.5}, "max_hole_fraction"), ({"max_hole_fraction": float("nan")}, "max_hole_fraction"),
    ({"max_hole_fraction": True}, "max_hole_fraction"),
    ({"veto_factor": "3"}, "veto_factor"), ({"shadow_min_ratio": None}, "shadow_min_ratio"),
    ({"filter_size": 7.0}, "filter_size"), ({"ground_intensity_margin": float("inf")}, "ground_intensity_margin"),
])
def test_parameters_are_validated(kwargs, match):
    with pytest.raises(InvalidInputError, match=match):
        SegmentationParameters(**kwargs)


def test_rejects_bad_arguments():
    with pytest.raises(InvalidInputError, match="reference"):
        segment(np.zeros((10, 10, 3), np.uint8), reference=(0, 0, 1, 1))
    with pytest.raises(InvalidInputError, match="shape"):
        segment(np.zeros((10, 10), np.uint8))


def _clean_up_reference(labels, darker, params):
    """The clean-up written with OpenCV component statistics (slow, obviously right)."""
    import cv2

    out = labels.copy()
    if params.min_obstacle_area_px > 1:
        _, components, stats, _ = cv2.connectedComponentsWithStats((out == Label.OBSTACLE).view(np.uint8),
                                                                    connectivity=8)
        small = stats[:, cv2.CC_STAT_AREA] < params.min_obstacle_area_px
        small[0] = False
        speck = small[components]
        out[speck] = Label.GROUND
        if darker is not None and params.shadow_rule:
            out[speck & darker] = Label.SHADOW
    if params.max_hole_area_px > 1:
        _, components, stats, _ = cv2.connectedComponentsWithStats((out != Label.OBSTACLE).view(np.uint8),
                                                                    connectivity=4)
        small = stats[:, cv2.CC_STAT_AREA] < params.max_hole_area_px
        small[0] = False
        out[small[components]] = Label.OBSTACLE
    return out


@pytest.mark.parametrize("seed", range(12))
def test_clean_up_matches_its_definition(seed):
    from stereo_obstacles.segmentation import _fill_holes, _remove_specks

    rng = np.random.default_rng(seed)
    height, width = (int(v) for v in rng.integers(1, 50, 2))
    labels = np.where(rng.uniform(size=(height, width)) < rng.uniform(0.2, 0.8), Label.OBSTACLE,
                      rng.integers(0, 3, (height, width))).astype(np.uint8)
    darker = rng.uniform(size=(height, width)) < 0.5 if seed % 3 else None
    params = SegmentationParameters(min_obstacle_area_px=int(rng.integers(0, 20)),
                                    max_hole_area_px=int(rng.integers(0, 20)), shadow_rule=seed % 4 != 0,
                                    max_hole_fraction=0.0)
    expected = _clean_up_reference(labels, darker, params)
    _remove_specks(labels, darker, params)
    _fill_holes(labels, params)
    np.testing.assert_array_equal(labels, expected)


def _enclosed_holes_reference(labels, max_area):
    """Enclosed-hole filling written with OpenCV component statistics (slow, obviously right)."""
    import cv2

    out = labels.copy()
    h, w = out.shape
    _, components, stats, _ = cv2.connectedComponentsWithStats((out != Label.OBSTACLE).view(np.uint8),
                                                                connectivity=4)
    x, y = stats[:, cv2.CC_STAT_LEFT], stats[:, cv2.CC_STAT_TOP]
    inside = (x > 0) & (y > 0) & (x + stats[:, cv2.CC_STAT_WIDTH] < w) & (y + stats[:, cv2.CC_STAT_HEIGHT] < h)
    enclosed = inside & (stats[:, cv2.CC_STAT_AREA] <= max_area)
    enclosed[0] = False
    out[enclosed[components]] = Label.OBSTACLE
    return out


@pytest.mark.parametrize("seed", range(12))
def test_enclosed_hole_filling_matches_its_definition(seed):
    from stereo_obstacles.segmentation import _fill_holes

    rng = np.random.default_rng(100 + seed)
    height, width = (int(v) for v in rng.integers(1, 50, 2))
    labels = np.where(rng.uniform(size=(height, width)) < rng.uniform(0.3, 0.8), Label.OBSTACLE,
                      rng.integers(0, 3, (height, width))).astype(np.uint8)
    max_area = int(rng.integers(0, 30))
    expected = _enclosed_holes_reference(labels, max_area)
    _fill_holes(labels, SegmentationParameters(max_hole_area_px=0,
                                               max_hole_fraction=min(1.0, (max_area + 0.5) / labels.size)))
    np.testing.assert_array_equal(labels, expected)


def test_the_inside_of_an_obstacle_outline_is_filled():
    image = _ground(GREEN)
    image[20:70, 50:110] = (200, 40, 40)                 # a red frame ...
    image[28:62, 58:102] = _ground(GREEN, (34, 44), seed=1)   # ... around a ground-coloured inside
    rgb = _u8(image)
    inside = np.s_[30:60, 60:100]
    tenth = SegmentationParameters(max_hole_fraction=0.1)    # 1920 px of this small image
    assert _fraction(segment(rgb, params=tenth).labels, inside, Label.OBSTACLE) == 1.0
    assert _fraction(segment(rgb).labels, inside, Label.GROUND) > 0.95   # 2 %: 384 px < the 1496 inside
    off = segment(rgb, params=SegmentationParameters(max_hole_fraction=0.0)).labels
    assert _fraction(off, inside, Label.GROUND) > 0.95
    image[28:62, 50:58] = _ground(GREEN, (34, 8), seed=2)    # open the frame on the left: no longer enclosed
    assert _fraction(segment(_u8(image), params=tenth).labels, inside, Label.GROUND) > 0.95
