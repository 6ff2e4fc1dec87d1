"""Scene layouts: the project's built-in default scene and random scenes per seed.

The default scene (:func:`default_scene`) is a pavement seen from 1.2 m with six
obstacles between 2 and 10 m -- a cardboard box, a thin pole, a blue bin, a brick wall
segment, a red crate and a dark block with the pavement's own hue (the hard case for
shadow-robust segmentation) -- a painted line and a bar on the ground, and a low
afternoon sun from the left. A tree outside the field of view casts its trunk and canopy
shadow across the ground right in front of the cameras (the reference area at the
bottom centre of the image), where the obstacles' shadows also fall.
"""

from __future__ import annotations

import math

import numpy as np

from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.synthetic.materials import (GROUND_MATERIALS, OBSTACLE_MATERIALS, dark_variant,
                                                  ground_material, material)
from stereo_obstacles.synthetic.primitives import Box, Cylinder, Sphere, bounding_corners
from stereo_obstacles.synthetic.rig import RightCameraError, StereoRig, camera_poses
from stereo_obstacles.synthetic.scene import Lighting, Marking, Obstacle, Scene

DEFAULT_SIZE = (640, 480)
"""Default image size ``(width, height)`` in pixels."""

DEFAULT_HFOV_DEG = 60.0
"""Horizontal field of view of the default rig, degrees."""


def _check_size(width_px: int, height_px: int) -> None:
    for name, value in (("width_px", width_px), ("height_px", height_px)):
        if not isinstance(value, int) or isinstance(value, bool) or not 16 <= value <= 8192:
            raise InvalidInputError(f"{name} must be an integer in [16, 8192], got {value!r}")


def default_rig(width_px: int = DEFAULT_SIZE[0], height_px: int = DEFAULT_SIZE[1], *,
                camera_height_m: float = 1.2, pitch_deg: float = 12.0, baseline_m: float = 0.12) -> StereoRig:
    """A walking-aid rig: 60 degree field of view, 12 cm baseline, 1.2 m high, 12 degrees down."""
    _check_size(width_px, height_px)
    return StereoRig.with_field_of_view(width_px, height_px, hfov_deg=DEFAULT_HFOV_DEG,
                                        camera_height_m=camera_height_m, pitch_deg=pitch_deg,
                                        baseline_m=baseline_m)


def _tree(obstacle_id: int, x: float, y: float, trunk_m: float, crown_m: float) -> Obstacle:
    """A trunk with a crown of three spheres (an off-screen shadow caster)."""
    parts = (Cylinder(x, y, 0.18, 0.0, trunk_m + 0.2 * crown_m),
             Sphere(x, y, trunk_m + crown_m * 0.7, crown_m),
             Sphere(x + 0.6 * crown_m, y + 0.5 * crown_m, trunk_m + 0.4 * crown_m, 0.75 * crown_m),
             Sphere(x - 0.5 * crown_m, y - 0.6 * crown_m, trunk_m + 0.5 * crown_m, 0.7 * crown_m))
    return Obstacle(obstacle_id, "tree", parts, material("bark"), material("foliage"))


def default_scene(width_px: int = DEFAULT_SIZE[0], height_px: int = DEFAULT_SIZE[1], *,
                  ground: str = "pavement") -> Scene:
    """The built-in demo scene (seed 0) at any image size (the field of view is fixed).

    Examples
    --------
    >>> scene = default_scene(320, 240)
    >>> [o.kind for o in scene.obstacles]
    ['box', 'pole', 'cylinder', 'wall', 'box', 'box', 'tree']
    """
    floor = ground_material(ground)
    obstacles = (
        Obstacle(1, "box", (Box(-1.15, -0.6, 3.0, 3.45, 0.0, 0.45),), material("cardboard")),
        Obstacle(2, "pole", (Cylinder(0.85, 4.6, 0.05, 0.0, 2.4),), material("metal")),
        Obstacle(3, "cylinder", (Cylinder(1.7, 6.8, 0.3, 0.0, 0.95),), material("blue_plastic")),
        Obstacle(4, "wall", (Box(-3.0, 0.3, 9.4, 9.6, 0.0, 1.1),), material("brick")),
        Obstacle(5, "box", (Box(0.15, 0.55, 3.9, 4.3, 0.0, 0.55),), dark_variant(floor)),
        Obstacle(6, "box", (Box(-2.2, -1.7, 6.5, 7.0, 0.0, 0.7),), material("red_plastic")),
        _tree(7, -3.76, 0.74, 3.8, 0.8),
    )
    markings = (
        Marking(-1.45, 8.5, 15.0, 0.12, 0.0, material("white_paint")),
        Marking(0.6, 5.6, 1.6, 0.3, 90.0, material("yellow_line")),
    )
    return Scene(rig=default_rig(width_px, height_px), ground=floor, obstacles=obstacles,
                 markings=markings, lighting=Lighting(250.0, 35.0), seed=0,
                 description={"layout": "default", "ground": ground})


def _in_view(rig: StereoRig, obstacle: Obstacle) -> bool:
    """True when the bounding box of ``obstacle`` may appear in either image."""
    for pose in camera_poses(rig, RightCameraError())[::2]:
        lo, hi = obstacle.bounds()
        u, v, z = pose.project(bounding_corners(Box(*(c for pair in zip(lo, hi) for c in pair))))
        if np.all(z <= 0):
            continue
        if np.any(z <= 0):
            return True
        if u.max() >= -0.5 and u.min() <= rig.width_px - 0.5 and v.max() >= -0.5 and v.min() <= rig.height_px - 0.5:
            return True
    return False


def _random_obstacle(rng: np.random.Generator, obstacle_id: int, x: float, y: float, floor) -> Obstacle:
    kind = rng.choice(["box", "box", "pole", "cylinder", "wall"])
    if obstacle_id == 1:
        kind = "dark"
    if kind == "pole":
        return Obstacle(obstacle_id, "pole", (Cylinder(x, y, float(rng.uniform(0.03, 0.08)), 0.0,
                                                       float(rng.uniform(1.2, 3.0))),),
                        material(str(rng.choice(["metal", "yellow_paint", "red_plastic"]))))
    if kind == "cylinder":
        return Obstacle(obstacle_id, "cylinder", (Cylinder(x, y, float(rng.uniform(0.15, 0.4)), 0.0,
                                                           float(rng.uniform(0.4, 1.2))),),
                        material(str(rng.choice(OBSTACLE_MATERIALS))))
    if kind == "wall":
        length, thick = float(rng.uniform(1.0, 3.0)), float(rng.uniform(0.1, 0.25))
        if rng.uniform() < 0.5:
            shape = Box(x - length / 2, x + length / 2, y, y + thick, 0.0, float(rng.uniform(0.6, 1.8)))
        else:
            shape = Box(x, x + thick, y - length / 2, y + length / 2, 0.0, float(rng.uniform(0.6, 1.8)))
        return Obstacle(obstacle_id, "wall", (shape,), material(str(rng.choice(["brick", "concrete", "green_paint"]))))
    w, d, h = (float(v) for v in rng.uniform([0.25, 0.25, 0.25], [0.9, 0.9, 1.0]))
    mat = dark_variant(floor, float(rng.uniform(0.35, 0.55))) if kind == "dark" else \
        material(str(rng.choice(OBSTACLE_MATERIALS)))
    return Obstacle(obstacle_id, "box", (Box(x - w / 2, x + w / 2, y - d / 2, y + d / 2, 0.0, h),), mat)


def random_scene(seed: int, *, width_px: int = DEFAULT_SIZE[0], height_px: int = DEFAULT_SIZE[1],
                 ground: str | None = None, sun_azimuth_deg: float | None = None,
                 sun_elevation_deg: float | None = None, n_obstacles: int | None = None,
                 camera_height_m: float | None = None, pitch_deg: float | None = None,
                 markings: bool = True) -> Scene:
    """A random scene for evaluations across many seeds; ``None`` options are drawn at random.

    Obstacles (3..7 unless ``n_obstacles`` is given, the first always a dark box of the
    ground's hue) stand 1.5..12 m ahead inside the field of view without touching each
    other; an off-screen tree is placed towards the sun from the area in front of the
    cameras so that its shadow usually falls there (it is kept out of both views).

    Examples
    --------
    >>> scene = random_scene(3, width_px=160, height_px=120, ground="grass")
    >>> scene.ground.name, scene.seed
    ('grass', 3)
    """
    if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
        raise InvalidInputError(f"seed must be an integer >= 0, got {seed!r}")
    rng = np.random.default_rng(seed)
    ground = ground if ground is not None else str(rng.choice(list(GROUND_MATERIALS)))
    floor = ground_material(ground)
    azimuth = float(rng.uniform(0.0, 360.0)) if sun_azimuth_deg is None else float(sun_azimuth_deg)
    elevation = float(rng.uniform(25.0, 60.0)) if sun_elevation_deg is None else float(sun_elevation_deg)
    lighting = Lighting(azimuth, elevation)
    rig = default_rig(width_px, height_px,
                      camera_height_m=float(rng.uniform(0.8, 1.6)) if camera_height_m is None else camera_height_m,
                      pitch_deg=float(rng.uniform(5.0, 18.0)) if pitch_deg is None else pitch_deg)
    count = int(rng.integers(3, 8)) if n_obstacles is None else n_obstacles
    if not isinstance(count, int) or not 0 <= count <= 20:
        raise InvalidInputError(f"n_obstacles must be an integer in [0, 20], got {n_obstacles!r}")

    half_fov = math.radians(DEFAULT_HFOV_DEG / 2)
    obstacles: list[Obstacle] = []
    attempts = 0
    while len(obstacles) < count and attempts < 200:
        attempts += 1
        y = float(rng.uniform(1.5 + 0.5 * len(obstacles) ** 0.5, 12.0))
        x = float(rng.uniform(-0.8, 0.8) * y * math.tan(half_fov))
        candidate = _random_obstacle(rng, len(obstacles) + 1, x, y, floor)
        lo, hi = candidate.bounds()
        clear = all(lo[0] > o.bounds()[1][0] + 0.3 or hi[0] < o.bounds()[0][0] - 0.3
                    or lo[1] > o.bounds()[1][1] + 0.3 or hi[1] < o.bounds()[0][1] - 0.3 for o in obstacles)
        if clear and lo[1] > 1.2 and _in_view(rig, candidate):
            obstacles.append(candidate)

    # The tree stands towards the sun from the reference area (about 90 % down the image),
    # out of view, tall enough that its trunk's shadow crosses that area and its crown's
    # shadow falls beyond it.
    sun = lighting.sun_direction()
    horizontal = sun[:2] / np.linalg.norm(sun[:2])
    half_vfov = math.atan((rig.height_px / 2.0) / rig.focal_px)
    target = np.array([0.0, rig.camera_height_m / math.tan(math.radians(rig.pitch_deg) + 0.8 * half_vfov)])
    crown = float(rng.uniform(0.6, 1.1))
    tree = None
    if rng.uniform() < 0.9:
        for reach in np.arange(2.5, 12.0, 0.5):
            base = target + reach * horizontal
            trunk = (reach + 1.0) * math.tan(math.radians(elevation))
            candidate = _tree(len(obstacles) + 1, float(base[0]), float(base[1]), trunk, crown)
            if not _in_view(rig, candidate):
                tree = candidate
                break
    if tree is not None:
        obstacles.append(tree)

    paint = []
    if markings:
        for _ in range(int(rng.integers(0, 3))):
            paint.append(Marking(float(rng.uniform(-2.0, 2.0)), float(rng.uniform(3.0, 12.0)),
                                 float(rng.uniform(0.5, 10.0)), float(rng.uniform(0.08, 0.4)),
                                 float(rng.choice([0.0, 90.0, rng.uniform(-45, 45)])),
                                 material(str(rng.choice(["white_paint", "yellow_line"])))))
    return Scene(rig=rig, ground=floor, obstacles=tuple(obstacles), markings=tuple(paint),
                 lighting=lighting, seed=seed,
                 description={"layout": "random", "ground": ground, "sun_azimuth_deg": azimuth,
                              "sun_elevation_deg": elevation, "n_obstacles": len(obstacles) - (tree is not None),
                              "off_screen_tree": tree is not None})
