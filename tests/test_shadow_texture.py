"""The shadow texture test: a cast shadow keeps the ground's texture, a smooth dark face does not."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from stereo_obstacles._shadow_texture_kernel import sampled_square_means_kernel
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.labels import Label
from stereo_obstacles.segmentation import SegmentationParameters, segment
from stereo_obstacles.shadow_texture import (ShadowTextureParameters, noise_floor, relative_texture,
                                             smooth_pixels, textureless_shadow)

REFERENCE = (0, 60, 120, 80)


def _textured(shape=(80, 120), seed=0, contrast=20.0) -> np.ndarray:
    """Blurred noise (a texture of a few pixels' grain) around grey 120, ``float32``."""
    rng = np.random.default_rng(seed)
    grain = cv2.GaussianBlur(rng.normal(0, 1, shape).astype(np.float32), (0, 0), 1.5)
    return 120.0 + contrast * grain / grain.std()


@pytest.mark.parametrize("sigma", [1.0, 2.0, 4.0])
def test_noise_floor_of_noise_on_a_smooth_ramp(sigma):
    rng = np.random.default_rng(1)
    ramp = np.add.outer(np.linspace(40, 200, 240), np.linspace(0, 30, 320))   # no texture
    grey = (ramp + rng.normal(0, sigma, ramp.shape)).astype(np.float32)
    # the 5th percentile of 9 x 9 window energies: about 0.6 of the noise variance
    assert 0.5 * sigma ** 2 < noise_floor(grey) < 0.7 * sigma ** 2


def test_noise_floor_ignores_texture_when_part_of_the_image_is_flat():
    rng = np.random.default_rng(2)
    grey = np.full((200, 200), 100.0)
    grey[:, 100:] = _textured((200, 100), contrast=30.0)
    grey = (grey + rng.normal(0, 2.0, grey.shape)).astype(np.float32)
    assert 0.5 * 4.0 < noise_floor(grey) < 0.7 * 4.0


@pytest.mark.parametrize("shape, window", [((37, 53), 9), ((40, 64), 9), ((9, 9), 9), ((5, 30), 9),
                                           ((1, 40), 9), ((2, 200), 9), ((3, 200), 9), ((6, 7), 31)])
def test_sampled_window_energies_are_the_blurred_squares_at_the_sampled_pixels(shape, window):
    """Also windows wider than the image, mirrored as often as needed (as OpenCV does)."""
    values = np.random.default_rng(shape[0]).normal(0, 3, shape).astype(np.float32)
    want = cv2.blur(values * values, (window, window), borderType=cv2.BORDER_REFLECT)[::4, ::4]
    got = np.empty(want.shape, np.float64)
    sampled_square_means_kernel(values, window, 4, got)
    np.testing.assert_allclose(got, want, rtol=1e-5)


def test_noise_floor_takes_odd_windows_only():
    grey = np.zeros((20, 20), np.float32)
    for window in (4, 0, 2.0, True):
        with pytest.raises(InvalidInputError, match="window_px"):
            noise_floor(grey, window_px=window)


def test_relative_texture_takes_the_noise_out_and_never_goes_negative():
    grey = np.zeros((30, 30), np.float32)
    grey[:, ::2] = 10.0           # columns of 0 and 10: a window holds 5 of one, 4 of the other
    relative, variance = relative_texture(grey, 5.0, 9)
    np.testing.assert_allclose(variance[10:20, 10:20], 100.0 * 20 / 81 - 5.0, rtol=1e-4)
    mean = cv2.blur(grey, (9, 9), borderType=cv2.BORDER_REFLECT)
    np.testing.assert_allclose(relative, np.sqrt(variance) / np.maximum(mean, 1.0), rtol=1e-6)
    relative, variance = relative_texture(grey, 100.0, 9)
    assert variance.min() == 0.0 and relative.min() == 0.0


def test_relative_texture_of_a_dark_window_is_divided_by_one_grey_level_at_least():
    grey = np.zeros((20, 20), np.float32)
    grey[::2, ::2] = 1.0          # window means below 1 grey level: divided by 1, not by the mean
    relative, variance = relative_texture(grey, 0.0, 3)
    np.testing.assert_allclose(relative[5:15, 5:15], np.sqrt(variance[5:15, 5:15]), rtol=1e-6)


def _scene():
    """Textured ground with sensor noise, a cast shadow (the same texture at half the light)
    and a smooth dark face (noise only) of the same brightness; both called shadow by colour."""
    rng = np.random.default_rng(3)
    ground = _textured()
    ground[10:40, 10:50] *= 0.5
    ground[10:40, 70:110] = 60.0
    grey = (ground + rng.normal(0, 1.5, ground.shape)).astype(np.float32)
    shadow = np.zeros(grey.shape, bool)
    shadow[10:40, 10:50] = shadow[10:40, 70:110] = True
    return grey, shadow


def test_a_cast_shadow_stays_and_a_smooth_dark_face_is_flagged():
    grey, shadow = _scene()
    flagged = textureless_shadow(smooth_pixels(grey, REFERENCE), shadow)
    assert np.mean(flagged[10:40, 10:50]) < 0.02
    assert np.all(flagged[18:32, 78:102])                 # the face, but for a rim where the
    assert np.mean(flagged[10:40, 70:110]) > 0.6          # windows see the ground's edge
    assert not flagged[~shadow].any()                     # only shadow pixels are ever flagged


def test_the_test_is_off_at_zero_and_on_ground_whose_texture_is_noise():
    grey, shadow = _scene()
    assert smooth_pixels(grey, REFERENCE, params=ShadowTextureParameters(min_relative_texture=0.0)) is None
    assert not textureless_shadow(None, shadow).any()
    rng = np.random.default_rng(4)
    noise_only = rng.normal(120, 3, grey.shape).astype(np.float32)   # no texture beyond the noise
    noise_only[10:40, 70:110] = rng.normal(60, 3, (30, 40))
    assert smooth_pixels(noise_only, REFERENCE) is None


def test_the_vote_drops_a_smooth_speck_of_shadowed_ground():
    grey, shadow = _scene()
    grey[18:30, 18:30] = 60.0                             # 12 x 12 smooth speck inside the shadow
    smooth = smooth_pixels(grey, REFERENCE)
    voted = textureless_shadow(smooth, shadow)
    raw = textureless_shadow(smooth, shadow, params=ShadowTextureParameters(vote_window_px=1))
    assert raw[24, 24] and not voted[18:30, 18:30].any()


def test_a_shadow_on_a_smooth_low_noise_floor_stays_shadow():
    """A flat floor with sensor noise well under a grey level: the rounding flicker of the lit
    reference is not texture a shadow must keep (the noise floor is at least 1/12)."""
    params = SegmentationParameters(colour_model="hsi")
    for sigma, level in ((0.2, 1.005), (0.3, 1.005), (0.3, 1.02)):
        rng = np.random.default_rng(0)
        image = np.broadcast_to(np.array((90.0, 140.0, 60.0)) * level, (120, 160, 3)).copy()
        image[20:70, 20:130] *= np.array((0.57, 0.625, 0.71))
        rgb = np.clip(np.rint(image + rng.normal(0, sigma, image.shape)), 0, 255).astype(np.uint8)
        labels = segment(rgb, params=params).labels
        assert np.mean(labels[25:65, 25:125] == Label.SHADOW) > 0.98, (sigma, level)


@pytest.mark.parametrize("kwargs, match", [
    ({"window_px": 4}, "window_px"), ({"vote_window_px": 0}, "vote_window_px"), ({"widen_px": -1}, "widen_px"),
    ({"min_relative_texture": -0.1}, "min_relative_texture"), ({"vote_fraction": 1.0}, "vote_fraction"),
    ({"noise_percentile": float("nan")}, "noise_percentile"), ({"min_reference_snr": -1}, "min_reference_snr"),
])
def test_parameters_are_validated(kwargs, match):
    with pytest.raises(InvalidInputError, match=match):
        ShadowTextureParameters(**kwargs)


def test_segment_turns_a_smooth_dark_face_read_as_shadow_into_an_obstacle():
    """On a textured green ground, a smooth face whose colour is the ground's in skylight: the
    colour rule alone calls it shadow; with the texture test it is an obstacle, while a real
    cast shadow (texture kept) stays shadow."""
    rgb, face, shadow = _face_and_shadow_scene()
    without = segment(rgb, params=SegmentationParameters(
        shadow_texture=ShadowTextureParameters(min_relative_texture=0.0))).labels
    with_test = segment(rgb).labels
    assert np.mean(without[face] == Label.SHADOW) > 0.9
    assert np.mean(with_test[face] == Label.OBSTACLE) > 0.9
    assert np.mean(with_test[shadow] == Label.SHADOW) > 0.9


def _face_and_shadow_scene(dtype=np.uint8):
    """Textured green ground with a cast shadow (left) and a smooth face of the shadow's colour
    (right); ``(rgb, face, shadow)`` regions."""
    rng = np.random.default_rng(5)
    texture = _textured((120, 160), seed=6, contrast=8.0)[..., None] / 120.0
    image = np.array((90.0, 140.0, 60.0)) * texture
    skylight = np.array((0.57, 0.625, 0.71))
    image[20:60, 10:70] *= skylight
    image[20:60, 90:150] = np.array((90.0, 140.0, 60.0)) * skylight
    rgb = np.clip(np.rint(image + rng.normal(0, 2.0, image.shape)), 0, 255)
    if dtype == np.uint16:
        rgb = rgb * 257.0
    return rgb.astype(dtype), np.s_[25:55, 95:145], np.s_[25:55, 15:65]


@pytest.mark.parametrize("case", ["hsi", "uint16", "with right image"])
def test_the_face_is_an_obstacle_in_every_mode(case, caplog):
    rgb, face, shadow = _face_and_shadow_scene(np.uint16 if case == "uint16" else np.uint8)
    params = SegmentationParameters(colour_model="hsi") if case == "hsi" else SegmentationParameters()
    # identical images: the ground check finds no sloping plane and is skipped with a warning,
    # so these labels come from the colour task that also computes the texture map
    right = rgb.copy() if case == "with right image" else None
    labels = segment(rgb, right=right, params=params).labels
    assert np.mean(labels[face] == Label.OBSTACLE) > 0.9
    assert np.mean(labels[shadow] == Label.SHADOW) > 0.9
    if right is not None:
        assert "stereo ground check skipped" in caplog.text


def test_segmentation_parameters_check_the_texture_settings():
    with pytest.raises(InvalidInputError, match="shadow_texture"):
        SegmentationParameters(shadow_texture={"min_relative_texture": 0.3})


@pytest.mark.slow
def test_synthetic_scenes_with_darkened_tiles_colour_alone():
    """Seeds 15 and 20 (boxes of darkened tiles read as shadow): colour-alone recall rises from
    below 30 % to above 70 %, shadows stay ground."""
    from stereo_obstacles.segmentation_evaluation import evaluate_synthetic, total

    off = SegmentationParameters(shadow_texture=ShadowTextureParameters(min_relative_texture=0.0))
    before = total(evaluate_synthetic([15, 20], stereo=False, params=off))
    after = total(evaluate_synthetic([15, 20], stereo=False))
    assert before.recall < 0.3
    assert after.recall > 0.7
    assert after.shadow_to_obstacle_rate < 0.02


def test_segment_command_records_the_texture_test_and_can_turn_it_off(tmp_path):
    import json

    from stereo_obstacles.cli import main
    from stereo_obstacles.fileio import read_labels, write_image

    rgb, face, _ = _face_and_shadow_scene()
    write_image(tmp_path / "in.png", rgb)
    records = {}
    for name, extra in (("on", []), ("off", ["--no-shadow-texture"])):
        out = tmp_path / f"{name}.png"
        assert main(["segment", str(tmp_path / "in.png"), "-o", str(out)] + extra) == 0
        records[name] = (read_labels(out), json.loads((tmp_path / f"{name}.png.json").read_text()))
    labels_on, record_on = records["on"]
    labels_off, record_off = records["off"]
    assert np.mean(labels_on[face] == Label.OBSTACLE) > 0.9 and np.mean(labels_off[face] == Label.SHADOW) > 0.9
    assert record_on["shadow_texture"]["made"] is True
    assert 0.05 < record_on["shadow_texture"]["obstacle_fraction"] < 0.2     # the face: 60 x 40 of 160 x 120
    assert record_off["shadow_texture"] == {"made": False, "obstacle_fraction": None}
