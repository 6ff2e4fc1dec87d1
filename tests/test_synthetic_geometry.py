"""Ray intersections, camera geometry and textures of the synthetic world against simple references."""

from __future__ import annotations

import numpy as np
import pytest

from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.synthetic import Box, Cylinder, Sphere, StereoRig, default_scene
from stereo_obstacles.synthetic.materials import MATERIALS
from stereo_obstacles.synthetic.raycast import trace
from stereo_obstacles.synthetic.rig import RightCameraError, camera_poses
from stereo_obstacles.synthetic.textures import MipTexture, periodic_noise


def _inside(shape, x, y, z):
    if isinstance(shape, Box):
        return ((x >= shape.x_min) & (x <= shape.x_max) & (y >= shape.y_min) & (y <= shape.y_max)
                & (z >= shape.z_min) & (z <= shape.z_max))
    if isinstance(shape, Cylinder):
        return ((x - shape.x) ** 2 + (y - shape.y) ** 2 <= shape.radius_m ** 2) & (z >= shape.z_min) & (z <= shape.z_max)
    return (x - shape.x) ** 2 + (y - shape.y) ** 2 + (z - shape.z) ** 2 <= shape.radius_m ** 2


def _marched_hit(shape, origin, direction, t_max=10.0, steps=20001):
    """First t at which a finely sampled ray is inside the solid (the obvious reference)."""
    t = np.linspace(0.0, t_max, steps)
    pts = origin[:, None] + direction[:, None] * t[None, :]
    inside = _inside(shape, *pts)
    return t[np.argmax(inside)] if inside.any() else np.inf


@pytest.mark.parametrize("shape", [Box(-0.3, 0.4, 2.0, 2.5, 0.0, 0.8), Cylinder(0.1, 3.0, 0.35, 0.0, 1.2),
                                   Sphere(-0.2, 2.5, 0.9, 0.5)])
def test_intersections_match_ray_marching(shape):
    rng = np.random.default_rng(1)
    origin = np.array([0.0, 0.0, 1.0])
    dirs = rng.normal([0.0, 1.0, -0.25], [0.2, 0.0, 0.2], size=(300, 3))
    t = shape.intersect(tuple(origin), tuple(dirs.T), 1e-9)
    hits = 0
    for i, d in enumerate(dirs):
        ref = _marched_hit(shape, origin, d)
        if np.isinf(ref):
            assert np.isinf(t[i]) or abs(np.linalg.norm(d) * (t[i] - ref)) < 1e-2
        else:
            hits += 1
            assert t[i] == pytest.approx(ref, abs=10.0 / 20000 + 1e-9)
    assert hits > 30


@pytest.mark.parametrize("shape", [Box(-0.3, 0.4, 2.0, 2.5, 0.0, 0.8), Cylinder(0.1, 3.0, 0.35, 0.0, 1.2),
                                   Sphere(-0.2, 2.5, 0.9, 0.5)])
def test_normals_are_unit_and_face_the_incoming_ray(shape):
    rng = np.random.default_rng(2)
    dirs = rng.normal([0.0, 1.0, -0.25], [0.2, 0.0, 0.2], size=(400, 3))
    t = shape.intersect((0.0, 0.0, 1.0), tuple(dirs.T), 1e-9)
    ok = np.isfinite(t)
    pts = tuple(np.array([0.0, 0.0, 1.0])[i] + t[ok] * dirs[ok, i] for i in range(3))
    n = np.stack(shape.normal(pts))
    np.testing.assert_allclose(np.linalg.norm(n, axis=0), 1.0, atol=1e-9)
    assert np.all(np.einsum("ij,ji->i", dirs[ok], n) < 0)


def test_bad_shapes_raise():
    with pytest.raises(InvalidInputError, match="x_max"):
        Box(1.0, 0.0, 0.0, 1.0, 0.0, 1.0)
    with pytest.raises(InvalidInputError, match="radius_m"):
        Cylinder(0.0, 1.0, -0.1, 0.0, 1.0)


def test_ground_depth_formula_matches_traced_ground():
    rig = StereoRig.with_field_of_view(80, 60, hfov_deg=60.0, camera_height_m=1.4, pitch_deg=10.0)
    left, _, _ = camera_poses(rig, RightCameraError())
    hits = trace(left, [])
    expected = np.repeat(rig.ground_depth_m(np.arange(60.0))[:, None], 80, axis=1)
    np.testing.assert_allclose(hits.depth, expected, rtol=1e-9)
    horizon = rig.horizon_row_px()
    assert np.all(np.isinf(hits.depth[: int(np.floor(horizon)) + 1]))
    assert np.all(np.isfinite(hits.depth[int(np.ceil(horizon)) + 1:]))


def test_world_points_project_back_to_their_pixels():
    rig = default_scene(64, 48).rig
    left, right, rectified = camera_poses(rig, RightCameraError())
    hits = trace(left, [])
    ground = np.isfinite(hits.depth)
    u, v, z = left.project_xyz(*(c[ground] for c in hits.point))
    vv, uu = np.nonzero(ground)
    np.testing.assert_allclose(u, uu, atol=1e-8)
    np.testing.assert_allclose(v, vv, atol=1e-8)
    np.testing.assert_allclose(z, hits.depth[ground], rtol=1e-12)
    # In the rectified right camera the same point is d = f B / Z to the left, on the same row.
    ur, vr, zr = rectified.project_xyz(*(c[ground] for c in hits.point))
    np.testing.assert_allclose(uu - ur, rig.focal_px * rig.baseline_m / z, rtol=1e-9)
    np.testing.assert_allclose(vr, vv, atol=1e-8)
    np.testing.assert_allclose(zr, z, rtol=1e-12)


def test_calibration_of_rig():
    rig = StereoRig(width_px=100, height_px=50, focal_px=80.0, baseline_m=0.2)
    cal = rig.calibration()
    assert (cal.focal_px, cal.cx_px, cal.cy_px, cal.baseline_m) == (80.0, 49.5, 24.5, 0.2)
    with pytest.raises(InvalidInputError, match="pitch_deg"):
        StereoRig(width_px=100, height_px=50, focal_px=80.0, pitch_deg=100.0)


def test_periodic_noise_tiles_seamlessly_and_is_normalised():
    noise = periodic_noise(np.random.default_rng(0), 64, 4.0)
    assert noise.mean() == pytest.approx(0.0, abs=1e-5) and noise.std() == pytest.approx(1.0, rel=1e-4)
    # Differences across the wrap-around seam look like differences inside the tile.
    inner = np.abs(np.diff(noise, axis=1)).mean()
    seam = np.abs(noise[:, 0] - noise[:, -1]).mean()
    assert seam < 1.5 * inner


def test_texture_lookup_is_periodic_and_filters_far_footprints():
    image = np.random.default_rng(0).uniform(0, 1, (32, 32, 3)).astype(np.float32)
    tex = MipTexture.from_image(image, texel_m=0.01)
    s = np.array([0.055, 0.123, 0.2])
    t = np.array([0.031, 0.3, 0.07])
    near = np.full(3, 1e-4)
    np.testing.assert_allclose(tex.sample(s, t, near), tex.sample(s + 0.32, t - 0.64, near), atol=1e-3)
    # At texel centres the finest level returns the texel itself.
    np.testing.assert_allclose(tex.sample(np.array([0.005]), np.array([0.015]), near[:1])[0], image[1, 0], atol=1e-3)
    # A footprint as large as the whole tile returns its mean colour.
    far = tex.sample(s, t, np.full(3, 10.0))
    np.testing.assert_allclose(far, np.broadcast_to(image.mean(axis=(0, 1)), far.shape), atol=1e-3)


def test_every_material_gives_valid_albedo():
    rng = np.random.default_rng(3)
    s, t = rng.uniform(-5, 5, 200), rng.uniform(0, 30, 200)
    for material in MATERIALS.values():
        a = material.albedo(s, t, np.full(200, 0.01))
        assert a.shape == (200, 3) and np.all((a >= 0) & (a <= 1.2)), material.name
        assert a.std(axis=0).max() > 0.002, material.name  # textured enough for stereo


@pytest.mark.parametrize("rotation", [0.5, "1,2,3", (0.1, 0.2)])
def test_a_right_camera_rotation_that_is_not_three_angles_is_refused(rotation):
    with pytest.raises(InvalidInputError, match="rotation_deg needs 3 angles"):
        RightCameraError(rotation_deg=rotation)
