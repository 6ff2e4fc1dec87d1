"""Vectorised ray casting: first hits of camera rays, and blocked lines of sight.

Camera rays come as ``(H, W)`` grids so that each solid is intersected only with the rays
inside the image rectangle its bounding box projects to; lines of sight from surface
points (to the sun, to the other camera) are culled the same way in a 2-D projection.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stereo_obstacles.synthetic.primitives import Primitive, Vec3, bounding_corners
from stereo_obstacles.synthetic.rig import CameraPose

HIT_EPS = 1e-7
"""Smallest ray parameter counted as a hit (rays start on or just off a surface)."""

SURFACE_OFFSET_M = 1e-4
"""Lines of sight start this far off the surface along its normal, against self-hits."""

SKY = -1
"""``owner`` of a ray that hits nothing."""
GROUND = 0
"""``owner`` of a ray that hits the ground plane (obstacles own their ``obstacle_id``)."""


@dataclass(frozen=True, eq=False)
class Hits:
    """First hits of a grid of camera rays (all arrays ``(H, W)``).

    Attributes
    ----------
    depth : numpy.ndarray
        float64 ray parameter = camera depth ``Z`` in metres, ``+inf`` for sky.
    owner : numpy.ndarray
        int16: :data:`SKY`, :data:`GROUND`, or the hit obstacle's ``obstacle_id``.
    primitive : numpy.ndarray
        int16 index into the primitive list, -1 for ground and sky.
    point, normal, direction : tuple of 3 numpy.ndarray
        World hit point (NaN for sky), outward unit normal, and the (unnormalised) ray direction.
    """

    depth: np.ndarray
    owner: np.ndarray
    primitive: np.ndarray
    point: Vec3
    normal: Vec3
    direction: Vec3


def _sample_window(pose: CameraPose, primitive: Primitive, supersample: int,
                   shape: tuple[int, int]) -> tuple[slice, slice] | None:
    """Rows and columns of the sample grid the primitive can cover; None when behind the camera."""
    u, v, z = pose.project(bounding_corners(primitive))
    if np.all(z <= 1e-9):
        return None
    if np.any(z <= 1e-9):
        return slice(0, shape[0]), slice(0, shape[1])
    s = supersample
    cols = (u + 0.5) * s - 0.5
    rows = (v + 0.5) * s - 0.5
    c0, c1 = int(max(np.floor(cols.min()) - 1, 0)), int(min(np.ceil(cols.max()) + 2, shape[1]))
    r0, r1 = int(max(np.floor(rows.min()) - 1, 0)), int(min(np.ceil(rows.max()) + 2, shape[0]))
    if c0 >= c1 or r0 >= r1:
        return None
    return slice(r0, r1), slice(c0, c1)


def trace(pose: CameraPose, primitives: list[tuple[Primitive, int]], supersample: int = 1) -> Hits:
    """First hit of every camera ray of ``pose`` (``s x s`` samples per pixel).

    Parameters
    ----------
    pose : CameraPose
        The camera.
    primitives : list of (Primitive, int)
        Solid shapes and the ``obstacle_id`` owning each.
    supersample : int
        Samples per pixel along each axis; the grids are ``(H * s, W * s)``.
    """
    dx, dy, dz = pose.ray_directions(supersample)
    shape = dx.shape
    oz = pose.centre[2]
    with np.errstate(divide="ignore"):
        depth = np.where(dz < 0, -oz / np.where(dz < 0, dz, -1.0), np.inf)
    owner = np.where(np.isfinite(depth), GROUND, SKY).astype(np.int16)
    prim_index = np.full(shape, -1, dtype=np.int16)
    origin = tuple(float(c) for c in pose.centre)
    for index, (primitive, obstacle_id) in enumerate(primitives):
        window = _sample_window(pose, primitive, supersample, shape)
        if window is None:
            continue
        t = primitive.intersect(origin, (dx[window], dy[window], dz[window]), HIT_EPS)
        closer = t < depth[window]
        depth[window] = np.where(closer, t, depth[window])
        owner[window] = np.where(closer, obstacle_id, owner[window])
        prim_index[window] = np.where(closer, index, prim_index[window])
    finite = np.isfinite(depth)
    t = np.where(finite, depth, np.nan)
    point = (origin[0] + t * dx, origin[1] + t * dy, origin[2] + t * dz)
    normal = [np.zeros(shape), np.zeros(shape), np.where(owner == GROUND, 1.0, 0.0)]
    for index in np.unique(prim_index[prim_index >= 0]):
        where = prim_index == index
        n = primitives[index][0].normal(tuple(c[where] for c in point))
        for axis in range(3):
            normal[axis][where] = n[axis]
    return Hits(depth, owner, prim_index, point, tuple(normal), (dx, dy, dz))


def blocked_towards_direction(points: Vec3, normals: Vec3, direction: np.ndarray,
                              primitives: list[Primitive]) -> np.ndarray:
    """True where the line from each surface point along ``direction`` (to the sun) is blocked.

    Culling: the line from ``p`` along ``L`` can only meet a solid whose shadow-projection
    onto ``z = 0`` along ``L`` covers the projection of ``p``.
    """
    lx, ly, lz = (float(c) for c in direction)
    ox, oy, oz = (p + SURFACE_OFFSET_M * n for p, n in zip(points, normals))
    blocked = np.zeros(ox.shape, dtype=bool)

    def project(x, y, z):
        return x - z * lx / lz, y - z * ly / lz

    px, py = project(ox, oy, oz)
    for primitive in primitives:
        corners = bounding_corners(primitive)
        cx, cy = project(corners[:, 0], corners[:, 1], corners[:, 2])
        idx = np.nonzero(~blocked & (px >= cx.min()) & (px <= cx.max()) & (py >= cy.min()) & (py <= cy.max()))
        if idx[0].size == 0:
            continue
        t = primitive.intersect((ox[idx], oy[idx], oz[idx]), (lx, ly, lz), HIT_EPS)
        blocked[idx] = np.isfinite(t)
    return blocked


def blocked_towards_point(points: Vec3, normals: Vec3, target_pose: CameraPose,
                          primitives: list[Primitive]) -> np.ndarray:
    """True where the segment from each surface point to the camera centre of ``target_pose`` is blocked.

    Culling: a solid can block the segment only if the point's image in that camera falls
    inside the image rectangle the solid's bounding box projects to.
    """
    centre = target_pose.centre
    ox, oy, oz = (p + SURFACE_OFFSET_M * n for p, n in zip(points, normals))
    direction = (centre[0] - ox, centre[1] - oy, centre[2] - oz)
    blocked = np.zeros(ox.shape, dtype=bool)
    pu, pv, _ = target_pose.project_xyz(ox, oy, oz)
    for primitive in primitives:
        u, v, z = target_pose.project(bounding_corners(primitive))
        if np.all(z <= 1e-9):
            continue  # wholly behind the camera: cannot lie between it and a visible point
        candidate = ~blocked
        if not np.any(z <= 1e-9):
            candidate &= (pu >= u.min()) & (pu <= u.max()) & (pv >= v.min()) & (pv <= v.max())
        idx = np.nonzero(candidate)
        if idx[0].size == 0:
            continue
        t = primitive.intersect((ox[idx], oy[idx], oz[idx]), tuple(d[idx] for d in direction), HIT_EPS)
        blocked[idx] = t < 1.0
    return blocked
