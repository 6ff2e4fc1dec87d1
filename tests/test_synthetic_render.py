"""Rendering options of the synthetic world: determinism, shadows, camera differences, sequences."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.labels import Label
from stereo_obstacles.synthetic import (RenderOptions, RightCameraError, default_scene, random_scene,
                                        render_pair, render_sequence)

W, H = 160, 120


@pytest.fixture(scope="module")
def small_pair():
    return render_pair(default_scene(W, H))


def test_outputs_have_documented_shapes_and_types(small_pair):
    p = small_pair
    assert p.left.shape == p.right.shape == (H, W, 3) and p.left.dtype == p.right.dtype == np.uint8
    for name in ("disparity", "depth"):
        assert getattr(p, name).shape == (H, W) and getattr(p, name).dtype == np.float32
    for name in ("labels", "instances"):
        assert getattr(p, name).shape == (H, W) and getattr(p, name).dtype == np.uint8
    assert p.nonocc.dtype == bool and p.cast_shadow.dtype == bool
    assert set(np.unique(p.labels)) <= {int(v) for v in Label}
    assert (p.calibration.width_px, p.calibration.height_px) == (W, H)


def test_same_seed_gives_identical_arrays_and_different_seeds_differ():
    options = RenderOptions(noise_sigma=2.0)
    a = render_pair(random_scene(5, width_px=W, height_px=H), options)
    b = render_pair(random_scene(5, width_px=W, height_px=H), options)
    c = render_pair(random_scene(6, width_px=W, height_px=H), options)
    for name in ("left", "right", "disparity", "labels", "nonocc"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert not np.array_equal(a.left, c.left)
    assert not np.array_equal(a.labels, c.labels)


def test_noise_has_the_requested_strength(small_pair):
    noisy = render_pair(small_pair.scene, RenderOptions(noise_sigma=3.0))
    diff = noisy.left.astype(float) - small_pair.left
    unsaturated = (small_pair.left > 20) & (small_pair.left < 235)
    assert diff[unsaturated].std() == pytest.approx(3.0, rel=0.1)
    np.testing.assert_array_equal(noisy.disparity, small_pair.disparity)


def test_jpeg_delivery_leaves_8x8_block_edges_and_keeps_the_truth(small_pair):
    compressed = render_pair(small_pair.scene, RenderOptions(jpeg_quality=40))
    grey = compressed.left.astype(float).mean(axis=2) - small_pair.left.astype(float).mean(axis=2)
    assert 0 < np.abs(grey).mean() < 6  # changed, not destroyed
    # the error steps across block boundaries (columns 7 | 8, 15 | 16, ...) more than inside blocks
    steps = np.abs(np.diff(grey, axis=1)).mean(axis=0)
    across = steps[7::8].mean()
    assert across > 1.3 * np.delete(steps, np.s_[7::8]).mean()
    np.testing.assert_array_equal(compressed.disparity, small_pair.disparity)
    with pytest.raises(InvalidInputError, match="jpeg_quality"):
        RenderOptions(jpeg_quality=101)


@pytest.mark.parametrize("ground", ["pavement", "grass", "tiles", "asphalt"])
def test_shadows_are_darker_and_bluer_than_lit_ground(ground):
    p = render_pair(default_scene(W, H, ground=ground))
    lit = p.left[p.labels == Label.GROUND].astype(float).mean(axis=0)
    shade = p.left[p.labels == Label.SHADOW].astype(float).mean(axis=0)
    assert np.all(shade < lit)
    assert shade.sum() < 0.8 * lit.sum()
    # Bluer: the blue share of the colour rises in shadow.
    assert shade[2] / shade.sum() > lit[2] / lit.sum() + 0.01


def test_no_shadows_option_removes_shadow_labels(small_pair):
    p = render_pair(small_pair.scene, RenderOptions(shadows=False))
    assert np.sum(small_pair.labels == Label.SHADOW) > 100
    assert np.sum(p.labels == Label.SHADOW) == 0
    assert not p.cast_shadow.any()


def _vertical_shift(left: np.ndarray, right: np.ndarray) -> float:
    grey_l = cv2.cvtColor(left, cv2.COLOR_RGB2GRAY).astype(np.float64)
    grey_r = cv2.cvtColor(right, cv2.COLOR_RGB2GRAY).astype(np.float64)
    (_, dy), _ = cv2.phaseCorrelate(grey_l, grey_r)
    return dy


def test_right_camera_rotation_and_offset_change_vertical_alignment(small_pair):
    base = _vertical_shift(small_pair.left, small_pair.right)
    tilted = render_pair(small_pair.scene, RenderOptions(right_error=RightCameraError((1.5, 0.0, 0.0))))
    shifted = render_pair(small_pair.scene, RenderOptions(right_error=RightCameraError(vertical_offset_px=4.0)))
    assert abs(base) < 0.5
    # 1.5 degrees of tilt moves the image by about f * tan(1.5 deg) = 3.6 px at this size.
    expected = small_pair.calibration.focal_px * np.tan(np.radians(1.5))
    assert abs(_vertical_shift(tilted.left, tilted.right)) == pytest.approx(expected, abs=1.0)
    assert abs(_vertical_shift(shifted.left, shifted.right)) == pytest.approx(4.0, abs=1.0)
    # The left view and its ground truth do not depend on the right camera.
    np.testing.assert_array_equal(tilted.left, small_pair.left)
    np.testing.assert_array_equal(tilted.disparity, small_pair.disparity)
    r, t = tilted.right_rotation, tilted.right_translation_m
    np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-12)
    assert np.degrees(np.arccos((np.trace(r) - 1) / 2)) == pytest.approx(1.5)
    assert np.linalg.norm(t) == pytest.approx(small_pair.calibration.baseline_m)
    np.testing.assert_allclose(small_pair.right_rotation, np.eye(3))
    np.testing.assert_allclose(small_pair.right_translation_m, [-small_pair.calibration.baseline_m, 0, 0])


def test_right_gain_and_bias_brighten_the_right_image(small_pair):
    p = render_pair(small_pair.scene, RenderOptions(right_gain=1.2, right_bias=5.0))
    mid = (small_pair.right > 20) & (small_pair.right < 200)
    ratio = (p.right[mid].astype(float) - 5.0) / small_pair.right[mid]
    assert np.median(ratio) == pytest.approx(1.2 ** (1 / 2.2), abs=0.02)
    np.testing.assert_array_equal(p.left, small_pair.left)


def test_sequence_moves_the_rig_forward():
    scene = default_scene(96, 72)
    frames = list(render_sequence(scene, 3, 0.5))
    assert [f.forward_m for f in frames] == [0.0, 0.5, 1.0]
    box = [next(o for o in f.obstacles if o.obstacle_id == 1) for f in frames]
    assert [b.forward_distance_m for b in box] == pytest.approx([3.0, 2.5, 2.0])
    assert box[0].nearest_depth_m > box[1].nearest_depth_m > box[2].nearest_depth_m
    assert not np.array_equal(frames[0].left, frames[1].left)


@pytest.mark.parametrize("kwargs, match", [
    ({"supersample": 0}, "supersample"),
    ({"noise_sigma": -1.0}, "noise_sigma"),
    ({"right_gain": 0.0}, "right_gain"),
    ({"blur_sigma_px": float("nan")}, "blur_sigma_px"),
])
def test_bad_render_options_raise(kwargs, match):
    with pytest.raises(InvalidInputError, match=match):
        RenderOptions(**kwargs)


def test_bad_scene_and_sequence_arguments_raise():
    with pytest.raises(InvalidInputError, match="rotation"):
        RightCameraError((30.0, 0.0, 0.0))
    with pytest.raises(InvalidInputError, match="ground"):
        default_scene(W, H, ground="lava")
    with pytest.raises(InvalidInputError, match="seed"):
        random_scene(-1)
    with pytest.raises(InvalidInputError, match="n_frames"):
        render_sequence(default_scene(W, H), 0, 0.1)
    with pytest.raises(InvalidInputError, match="width_px"):
        default_scene(8, 8)


def test_supersampling_keeps_the_ground_truth_and_smooths_edges(small_pair):
    p = render_pair(small_pair.scene, RenderOptions(supersample=2))
    np.testing.assert_array_equal(p.labels, small_pair.labels)
    np.testing.assert_array_equal(p.disparity, small_pair.disparity)
    assert np.abs(p.left.astype(int) - small_pair.left).mean() < 6
