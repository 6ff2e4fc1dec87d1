"""The synthetic world's ground truth checked against the images and against the geometry."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from stereo_obstacles.labels import Label
from stereo_obstacles.synthetic import default_scene, random_scene, render_pair


@pytest.fixture(scope="module")
def pair():
    return render_pair(default_scene(320, 240))


def warp_errors(pair) -> tuple[float, float]:
    """Mean absolute RGB error (grey levels) of the right image warped to the left with the
    true disparity, and with zero disparity, over non-occluded non-sky pixels."""
    h, w = pair.disparity.shape
    map_x = (np.arange(w)[None, :] - np.nan_to_num(pair.disparity)).astype(np.float32)
    map_y = np.repeat(np.arange(h, dtype=np.float32)[:, None], w, axis=1)
    warped = cv2.remap(pair.right, map_x, map_y, cv2.INTER_LINEAR).astype(np.float64)
    valid = pair.nonocc & (pair.labels != Label.SKY)
    left = pair.left.astype(np.float64)
    err = np.abs(warped - left).mean(axis=2)[valid].mean()
    err_zero = np.abs(pair.right.astype(np.float64) - left).mean(axis=2)[valid].mean()
    return float(err), float(err_zero)


def test_right_image_warped_with_true_disparity_matches_left(pair):
    # Measured: 0.67 grey levels against 12.5 with zero disparity (ratio 0.05).
    err, err_zero = warp_errors(pair)
    assert err < 1.5
    assert err < 0.15 * err_zero


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_warp_check_holds_on_random_scenes(seed):
    # Measured at 320x240: ratios 0.04-0.08 on asphalt and tiles.
    err, err_zero = warp_errors(render_pair(random_scene(seed, width_px=160, height_px=120)))
    assert err < 2.0
    assert err < 0.3 * err_zero


def test_disparity_is_focal_times_baseline_over_depth(pair):
    cal = pair.calibration
    solid = np.isfinite(pair.depth)
    np.testing.assert_allclose(pair.disparity[solid], cal.focal_px * cal.baseline_m / pair.depth[solid], rtol=1e-5)
    assert np.all(np.isnan(pair.disparity[~solid]))
    assert pair.disparity.dtype == np.float32 and pair.depth.dtype == np.float32


def _ground_depth(pair) -> np.ndarray:
    rows = np.arange(pair.depth.shape[0], dtype=np.float64)
    return np.repeat(pair.scene.rig.ground_depth_m(rows)[:, None], pair.depth.shape[1], axis=1)


def test_ground_and_shadowed_ground_pixels_have_ground_plane_depth(pair):
    ground = _ground_depth(pair)
    for label in (Label.GROUND, Label.SHADOW, Label.MARKING):
        mask = pair.labels == label
        assert mask.sum() > 100, label
        np.testing.assert_allclose(pair.depth[mask], ground[mask], rtol=1e-5)


def test_obstacle_pixels_are_closer_than_the_ground_behind_them(pair):
    ground = _ground_depth(pair)
    mask = pair.labels == Label.OBSTACLE
    assert mask.sum() > 1000
    assert np.all(pair.depth[mask] < ground[mask])


def test_sky_pixels_have_no_ground_intersection_and_no_depth(pair):
    sky = pair.labels == Label.SKY
    assert sky.sum() > 1000
    assert np.all(np.isinf(_ground_depth(pair)[sky]))
    assert np.all(np.isnan(pair.depth[sky]))


def test_instances_agree_with_labels(pair):
    assert np.array_equal(pair.instances > 0, pair.labels == Label.OBSTACLE)


def test_cast_shadow_mask_agrees_with_shadow_label(pair):
    on_ground = np.isin(pair.labels, [Label.GROUND, Label.SHADOW])
    assert np.array_equal(pair.cast_shadow[on_ground], pair.labels[on_ground] == Label.SHADOW)


def test_obstacle_positions_project_onto_obstacle_pixels(pair):
    k = pair.scene.rig.intrinsic_matrix()
    visible = [o for o in pair.obstacles if o.visible_pixels > 0]
    assert len(visible) == 6
    for obstacle in visible:
        x, y, z = obstacle.centre_camera_m
        u, v = k[0, 0] * x / z + k[0, 2], k[1, 1] * y / z + k[1, 2]
        ui, vi = int(round(u)), int(round(v))
        if not (0 <= ui < pair.depth.shape[1] and 0 <= vi < pair.depth.shape[0]):
            continue  # the pole's centre is above the image
        patch = pair.labels[max(vi - 1, 0):vi + 2, max(ui - 1, 0):ui + 2]
        assert np.any(patch == Label.OBSTACLE), obstacle
        u0, v0, u1, v1 = obstacle.image_box_px
        assert u0 <= u <= u1 and v0 <= v <= v1


def test_obstacle_distances_are_known_answers(pair):
    box = next(o for o in pair.obstacles if o.obstacle_id == 1)  # x -1.15..-0.6, y 3.0..3.45
    assert box.distance_m == pytest.approx(np.hypot(0.6, 3.0))
    assert box.forward_distance_m == pytest.approx(3.0)
    assert box.size_m == pytest.approx((0.55, 0.45, 0.45))
    pole = next(o for o in pair.obstacles if o.kind == "pole")  # centre (0.85, 4.6), radius 0.05
    assert pole.distance_m == pytest.approx(np.hypot(0.85, 4.6) - 0.05)
    # The nearest visible point is no nearer than the footprint's nearest point allows.
    for o in pair.obstacles:
        if o.nearest_depth_m is not None:
            assert o.nearest_depth_m > 0.9 * o.forward_distance_m
    distances = [o.distance_m for o in pair.obstacles]
    assert distances == sorted(distances)


def test_off_screen_tree_is_invisible_but_shades_the_reference_area(pair):
    tree = next(o for o in pair.obstacles if o.kind == "tree")
    assert tree.visible_pixels == 0
    h, w = pair.labels.shape
    reference = pair.labels[int(0.8 * h):, int(0.35 * w):int(0.65 * w)]
    shadow_fraction = np.mean(reference == Label.SHADOW)
    assert 0.1 < shadow_fraction < 0.9


def test_nonocc_marks_background_hidden_from_the_right_camera(pair):
    h, w = pair.labels.shape
    assert 0.02 < np.mean(~pair.nonocc[pair.labels != Label.SKY]) < 0.15
    # Left of the cardboard box the right camera sees the box, not the ground behind it.
    u0, v0, u1, v1 = next(o for o in pair.obstacles if o.obstacle_id == 1).image_box_px
    v_mid = (v0 + v1) // 2
    strip = pair.nonocc[v_mid, max(u0 - 4, 0):u0]
    assert not strip.all()
    # The leftmost columns cannot be seen by the right camera at all (u - d < 0).
    assert not pair.nonocc[:, 0].any()
    assert pair.nonocc[pair.labels == Label.SKY].sum() == 0


def test_nonocc_agrees_with_the_right_views_own_depth(pair):
    """Independent check: trace the rectified right camera and compare depths at u - d."""
    from stereo_obstacles.synthetic.raycast import trace
    from stereo_obstacles.synthetic.rig import RightCameraError, camera_poses

    scene = pair.scene
    _, _, rectified = camera_poses(scene.rig, RightCameraError())
    right_depth = trace(rectified, [(p, oid) for p, oid, _ in scene.primitives()]).depth
    h, w = pair.depth.shape
    v, u = np.nonzero(np.isfinite(pair.depth))
    ur = u - pair.disparity[v, u]
    inside = (ur >= 0) & (ur <= w - 1)
    v, u, ur = v[inside], u[inside], ur[inside]
    # The right depth at both neighbours of u - d (rows are shared in the rectified pair).
    z = pair.depth[v, u].astype(np.float64)
    z_lo, z_hi = right_depth[v, np.floor(ur).astype(int)], right_depth[v, np.ceil(ur).astype(int)]
    same = (np.abs(z_lo - z) < 0.02 * z) | (np.abs(z_hi - z) < 0.02 * z)
    # An occluder edge may pass between the two neighbours, so one nearer neighbour suffices.
    nearer = (z_lo < 0.98 * z) | (z_hi < 0.98 * z)
    visible = pair.nonocc[v, u]
    assert np.mean(same[visible]) > 0.99
    assert (~visible).sum() > 50
    assert np.mean(nearer[~visible]) > 0.99
