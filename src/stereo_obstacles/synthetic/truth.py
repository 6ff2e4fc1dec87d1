"""Ground-truth records of the obstacles in a rendered view.

Distances are given three ways, because "how far is it" has several honest answers:

* ``distance_m`` -- horizontal distance on the ground from the point below the left camera
  to the nearest point of the obstacle's footprint: how far one can walk before touching it;
* ``forward_distance_m`` -- the same measured along the walking direction (world ``y``) only,
  to the nearest footprint point (0 when the footprint spans the camera's position);
* ``nearest_depth_m`` -- the smallest camera depth ``Z`` among the obstacle's visible pixels
  in the left image: what stereo can measure at best (``None`` when it is not visible).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from stereo_obstacles.synthetic.primitives import Cylinder
from stereo_obstacles.synthetic.rig import CameraPose
from stereo_obstacles.synthetic.scene import Obstacle


@dataclass(frozen=True)
class ObstacleTruth:
    """What is known exactly about one obstacle in one left view.

    Attributes
    ----------
    obstacle_id : int
        Its value in the instance image.
    kind, material, colour_name : str
        Shape kind, material name and plain colour name.
    size_m : tuple of 3 floats
        Width (world x), depth (world y) and height of its bounding box, metres.
    base_centre_world_m : tuple of 3 floats
        Centre of its footprint on the ground, world frame (z = 0).
    base_centre_camera_m, centre_camera_m : tuple of 3 floats
        Footprint centre and bounding-box centre in the left camera frame (X right, Y down,
        Z forward), metres.
    distance_m, forward_distance_m : float
        See the module docstring.
    nearest_depth_m : float or None
        Smallest depth Z of its visible left pixels, metres.
    visible_pixels : int
        Number of left pixels showing it (0 for an off-screen shadow caster).
    image_box_px : tuple of 4 ints or None
        ``(u_min, v_min, u_max, v_max)`` of its visible pixels, inclusive.
    """

    obstacle_id: int
    kind: str
    material: str
    colour_name: str
    size_m: tuple[float, float, float]
    base_centre_world_m: tuple[float, float, float]
    base_centre_camera_m: tuple[float, float, float]
    centre_camera_m: tuple[float, float, float]
    distance_m: float
    forward_distance_m: float
    nearest_depth_m: float | None
    visible_pixels: int
    image_box_px: tuple[int, int, int, int] | None


def _footprint_distance(obstacle: Obstacle, x: float, y: float) -> tuple[float, float]:
    """Horizontal and forward distance from ground point ``(x, y)`` to the footprint."""
    main = obstacle.primitives[0]
    if isinstance(main, Cylinder):
        horizontal = max(0.0, math.hypot(main.x - x, main.y - y) - main.radius_m)
        forward = max(0.0, main.y - main.radius_m - y)
        return horizontal, forward
    lo, hi = obstacle.bounds()
    dx = max(lo[0] - x, 0.0, x - hi[0])
    dy = max(lo[1] - y, 0.0, y - hi[1])
    return math.hypot(dx, dy), max(0.0, lo[1] - y)


def obstacle_truths(obstacles: tuple[Obstacle, ...], left: CameraPose, depth: np.ndarray,
                    instances: np.ndarray) -> tuple[ObstacleTruth, ...]:
    """One :class:`ObstacleTruth` per obstacle, nearest first by ``distance_m``."""
    records = []
    cam_x, cam_y = float(left.centre[0]), float(left.centre[1])
    r = left.world_from_camera

    def to_camera(p: np.ndarray) -> tuple[float, float, float]:
        return tuple(float(c) for c in (p - left.centre) @ r)

    for obstacle in obstacles:
        lo, hi = obstacle.bounds()
        main = obstacle.primitives[0]
        base = np.array([main.x, main.y, 0.0]) if isinstance(main, Cylinder) else \
            np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, 0.0])
        mask = instances == obstacle.obstacle_id
        count = int(mask.sum())
        box = None
        nearest = None
        if count:
            vs, us = np.nonzero(mask)
            box = (int(us.min()), int(vs.min()), int(us.max()), int(vs.max()))
            nearest = float(np.nanmin(depth[mask]))
        horizontal, forward = _footprint_distance(obstacle, cam_x, cam_y)
        records.append(ObstacleTruth(
            obstacle_id=obstacle.obstacle_id, kind=obstacle.kind, material=obstacle.material.name,
            colour_name=obstacle.material.colour_name,
            size_m=tuple(float(c) for c in hi - lo),
            base_centre_world_m=tuple(float(c) for c in base),
            base_centre_camera_m=to_camera(base),
            centre_camera_m=to_camera((lo + hi) / 2),
            distance_m=horizontal, forward_distance_m=forward,
            nearest_depth_m=nearest, visible_pixels=count, image_box_px=box))
    return tuple(sorted(records, key=lambda rec: (rec.distance_m, rec.obstacle_id)))
