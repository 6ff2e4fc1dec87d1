"""Radiance of what each camera ray sees: textured surfaces under sun and sky, or the sky.

Surface radiance (linear units) is ``albedo * (sun * max(0, n.l) * lit + sky * (1 + n_z) / 2)``:
direct sunlight where the sun is not blocked, plus bluish skylight weighted by how much of
the sky the surface faces. A surface in cast shadow keeps only the skylight, so it is darker
and bluer than the same surface in the sun. Distant surfaces fade slightly towards the
horizon colour (aerial haze); rays that hit nothing see a sky gradient.
"""

from __future__ import annotations

import numpy as np

from stereo_obstacles.synthetic.materials import Material
from stereo_obstacles.synthetic.primitives import Primitive
from stereo_obstacles.synthetic.raycast import GROUND, Hits
from stereo_obstacles.synthetic.scene import Lighting

HAZE_DISTANCE_M = 400.0
"""Distance at which haze has replaced 63 % of a surface's radiance by the horizon colour."""

_SKY_HORIZON = np.array([0.42, 0.44, 0.47])
_SKY_ZENITH = np.array([0.16, 0.24, 0.42])


def sky_radiance(dx: np.ndarray, dy: np.ndarray, dz: np.ndarray) -> np.ndarray:
    """Sky colour ``(N, 3)`` for ray directions: pale at the horizon, deeper blue overhead."""
    elevation = np.arcsin(np.clip(dz / np.sqrt(dx * dx + dy * dy + dz * dz), -1.0, 1.0))
    w = np.sqrt(np.clip(elevation / (np.pi / 2), 0.0, 1.0))[:, None]
    return _SKY_HORIZON * (1.0 - w) + _SKY_ZENITH * w


def surface_albedo(hits: Hits, flat: np.ndarray, primitives: list[tuple[Primitive, int, Material]],
                   ground: Material,
                   marking_material: np.ndarray, markings: list[Material], focal_px: float,
                   supersample: int) -> np.ndarray:
    """Albedo ``(N, 3)`` of the hit surfaces at the flat sample indices ``flat``.

    ``marking_material`` holds, per sample, the index of the marking painted there (-1 none).
    """
    point = tuple(c.ravel()[flat] for c in hits.point)
    normal = tuple(c.ravel()[flat] for c in hits.normal)
    direction = tuple(c.ravel()[flat] for c in hits.direction)
    depth = hits.depth.ravel()[flat]
    prim = hits.primitive.ravel()[flat]
    owner = hits.owner.ravel()[flat]
    paint = marking_material.ravel()[flat]
    length = np.sqrt(sum(d * d for d in direction))
    cos_incidence = np.abs(sum(n * d for n, d in zip(normal, direction))) / length
    footprint = depth * length / (focal_px * supersample) / np.sqrt(np.maximum(cos_incidence, 0.05))
    albedo = np.zeros((flat.size, 3), dtype=np.float32)
    groups: list[tuple[np.ndarray, Material, np.ndarray, np.ndarray]] = []
    on_ground = owner == GROUND
    for index, mat in enumerate([ground, *markings]):
        sel = np.nonzero(on_ground & (paint == index - 1))[0]
        groups.append((sel, mat, point[0][sel], point[1][sel]))
    for index in np.unique(prim[prim >= 0]):
        sel = np.nonzero(prim == index)[0]
        primitive, obstacle_id, mat = primitives[index]
        u, v = primitive.surface_uv(tuple(c[sel] for c in point), tuple(c[sel] for c in normal))
        # Shift each obstacle within the texture so equal materials do not look cloned.
        groups.append((sel, mat, u + 1.37 * obstacle_id, v + 0.71 * obstacle_id))
    for sel, mat, s, t in groups:
        if sel.size:
            albedo[sel] = mat.albedo(s, t, footprint[sel])
    return albedo


def shade(hits: Hits, albedo: np.ndarray, flat: np.ndarray, sun_visible: np.ndarray,
          lighting: Lighting) -> np.ndarray:
    """Linear radiance ``(H * W, 3)`` of every sample (surfaces at ``flat``, sky elsewhere)."""
    dx, dy, dz = (c.ravel() for c in hits.direction)
    radiance = np.empty((dx.size, 3))
    sky = np.ones(dx.size, dtype=bool)
    sky[flat] = False
    radiance[sky] = sky_radiance(dx[sky], dy[sky], dz[sky])
    nx, ny, nz = (c.ravel()[flat] for c in hits.normal)
    sun = lighting.sun_direction()
    cos_sun = np.maximum(nx * sun[0] + ny * sun[1] + nz * sun[2], 0.0) * sun_visible
    irradiance = (np.asarray(lighting.sun_irradiance_rgb) * cos_sun[:, None]
                  + np.asarray(lighting.sky_irradiance_rgb) * ((1.0 + nz) / 2.0)[:, None])
    surface = albedo * irradiance
    dist = hits.depth.ravel()[flat] * np.sqrt(dx[flat] ** 2 + dy[flat] ** 2 + dz[flat] ** 2)
    haze = (1.0 - np.exp(-dist / HAZE_DISTANCE_M))[:, None]
    radiance[flat] = surface * (1.0 - haze) + _SKY_HORIZON * haze
    return radiance

