"""Solid shapes of the synthetic world and their vectorised ray intersections.

World frame (metres): ``x`` to the right of the rig, ``y`` forward along the ground, ``z`` up;
the ground is the plane ``z = 0``. Every shape here is a closed solid: an axis-aligned
:class:`Box` (also used for thin wall segments), a vertical :class:`Cylinder` (poles, bins,
tree trunks) and a :class:`Sphere` (tree canopies).

Rays are ``origin + t * direction`` with the components given as separate arrays that
broadcast against each other (a camera's single origin against a grid of directions, or a
grid of surface points against the single sun direction). ``intersect`` returns the
smallest ``t > eps`` at which the ray enters the solid, ``+inf`` where it misses; rays
starting inside a solid are not used by the renderer.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from stereo_obstacles.errors import InvalidInputError

Vec3 = tuple[np.ndarray, np.ndarray, np.ndarray]
"""Three broadcastable arrays: the x, y and z components of points or directions."""


def _require_positive(owner: str, **values: float) -> None:
    for name, value in values.items():
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise InvalidInputError(f"{owner} {name} must be a finite number > 0, got {value!r}")


def _require_finite(owner: str, **values: float) -> None:
    for name, value in values.items():
        if not (isinstance(value, (int, float)) and math.isfinite(value)):
            raise InvalidInputError(f"{owner} {name} must be a finite number, got {value!r}")


@dataclass(frozen=True)
class Box:
    """Axis-aligned box ``[x_min, x_max] x [y_min, y_max] x [z_min, z_max]`` in metres."""

    x_min: float
    x_max: float
    y_min: float
    y_max: float
    z_min: float
    z_max: float

    def __post_init__(self) -> None:
        _require_finite("Box", **{k: getattr(self, k) for k in
                                  ("x_min", "x_max", "y_min", "y_max", "z_min", "z_max")})
        for axis in "xyz":
            lo, hi = getattr(self, f"{axis}_min"), getattr(self, f"{axis}_max")
            if not hi > lo:
                raise InvalidInputError(f"Box {axis}_max must exceed {axis}_min, got {lo} .. {hi}")

    def bounds(self) -> np.ndarray:
        """``(2, 3)`` array: the minimum and maximum corner (x, y, z) in metres."""
        return np.array([[self.x_min, self.y_min, self.z_min],
                         [self.x_max, self.y_max, self.z_max]])

    def intersect(self, origin: Vec3, direction: Vec3, eps: float) -> np.ndarray:
        """Entry parameter ``t`` of each ray (slab method), ``+inf`` where it misses."""
        t_near = None
        t_far = None
        with np.errstate(divide="ignore", invalid="ignore"):
            for o, d, lo, hi in zip(origin, direction, self.bounds()[0], self.bounds()[1]):
                inv = 1.0 / d
                t1 = (lo - o) * inv
                t2 = (hi - o) * inv
                near = np.fmin(t1, t2)
                far = np.fmax(t1, t2)
                t_near = near if t_near is None else np.fmax(t_near, near)
                t_far = far if t_far is None else np.fmin(t_far, far)
        hit = (t_near <= t_far) & (t_near > eps)
        return np.where(hit, t_near, np.inf)

    def normal(self, point: Vec3) -> Vec3:
        """Outward unit normal of the face each surface ``point`` lies on."""
        x, y, z = point
        # The face nearest to the point is the one it lies on (ties at edges pick either).
        dist = np.stack([np.abs(x - self.x_min), np.abs(x - self.x_max),
                         np.abs(y - self.y_min), np.abs(y - self.y_max),
                         np.abs(z - self.z_min), np.abs(z - self.z_max)])
        face = np.argmin(dist, axis=0)
        sign = np.where(face % 2 == 0, -1.0, 1.0)
        axis = face // 2
        return tuple(np.where(axis == k, sign, 0.0) for k in range(3))

    def surface_uv(self, point: Vec3, normal: Vec3) -> tuple[np.ndarray, np.ndarray]:
        """Texture coordinates in metres on the face (the two in-face world axes)."""
        x, y, z = point
        nx, ny, _ = normal
        u = np.where(nx != 0, y, x)
        v = np.where((nx != 0) | (ny != 0), z, y)
        return u, v


@dataclass(frozen=True)
class Cylinder:
    """Vertical cylinder of radius ``radius_m`` around ``(x, y)``, from ``z_min`` to ``z_max``."""

    x: float
    y: float
    radius_m: float
    z_min: float
    z_max: float

    def __post_init__(self) -> None:
        _require_finite("Cylinder", x=self.x, y=self.y, z_min=self.z_min, z_max=self.z_max)
        _require_positive("Cylinder", radius_m=self.radius_m)
        if not self.z_max > self.z_min:
            raise InvalidInputError(f"Cylinder z_max must exceed z_min, got {self.z_min} .. {self.z_max}")

    def bounds(self) -> np.ndarray:
        """``(2, 3)`` array: the minimum and maximum corner of the bounding box in metres."""
        r = self.radius_m
        return np.array([[self.x - r, self.y - r, self.z_min], [self.x + r, self.y + r, self.z_max]])

    def intersect(self, origin: Vec3, direction: Vec3, eps: float) -> np.ndarray:
        """Entry parameter ``t`` of each ray through the side or a cap, ``+inf`` where it misses."""
        ox, oy, oz = origin
        dx, dy, dz = direction
        px, py = ox - self.x, oy - self.y
        r2 = self.radius_m ** 2
        a = dx * dx + dy * dy
        b = 2.0 * (dx * px + dy * py)
        c = px * px + py * py - r2
        disc = b * b - 4.0 * a * c
        with np.errstate(divide="ignore", invalid="ignore"):
            t_side = (-b - np.sqrt(np.maximum(disc, 0.0))) / (2.0 * a)
            z_side = oz + t_side * dz
            side = (disc >= 0) & (a > 0) & (t_side > eps) & (z_side >= self.z_min) & (z_side <= self.z_max)
            best = np.where(side, t_side, np.inf)
            for z_cap in (self.z_min, self.z_max):
                t_cap = (z_cap - oz) / dz
                cx_, cy_ = px + t_cap * dx, py + t_cap * dy
                cap = (t_cap > eps) & (cx_ * cx_ + cy_ * cy_ <= r2)
                best = np.where(cap, np.fmin(best, t_cap), best)
        return best

    def normal(self, point: Vec3) -> Vec3:
        """Outward unit normal: radial on the side, vertical on the caps."""
        x, y, z = point
        rx, ry = (x - self.x) / self.radius_m, (y - self.y) / self.radius_m
        # A point is on a cap when it is nearer to the cap plane than to the side (relative).
        radial = 1.0 - np.hypot(rx, ry)
        on_top = np.abs(z - self.z_max) < np.maximum(radial * self.radius_m, 1e-9)
        on_bottom = np.abs(z - self.z_min) < np.maximum(radial * self.radius_m, 1e-9)
        cap = on_top | on_bottom
        norm = np.maximum(np.hypot(rx, ry), 1e-12)
        nz = np.where(on_top, 1.0, np.where(on_bottom, -1.0, 0.0))
        return np.where(cap, 0.0, rx / norm), np.where(cap, 0.0, ry / norm), nz

    def surface_uv(self, point: Vec3, normal: Vec3) -> tuple[np.ndarray, np.ndarray]:
        """Texture coordinates in metres: arc length around the axis and height (caps: x, y)."""
        x, y, z = point
        arc = np.arctan2(y - self.y, x - self.x) * self.radius_m
        cap = normal[2] != 0
        return np.where(cap, x, arc), np.where(cap, y, z)


@dataclass(frozen=True)
class Sphere:
    """Sphere of radius ``radius_m`` centred at ``(x, y, z)`` metres."""

    x: float
    y: float
    z: float
    radius_m: float

    def __post_init__(self) -> None:
        _require_finite("Sphere", x=self.x, y=self.y, z=self.z)
        _require_positive("Sphere", radius_m=self.radius_m)

    def bounds(self) -> np.ndarray:
        """``(2, 3)`` array: the minimum and maximum corner of the bounding box in metres."""
        c = np.array([self.x, self.y, self.z])
        return np.stack([c - self.radius_m, c + self.radius_m])

    def intersect(self, origin: Vec3, direction: Vec3, eps: float) -> np.ndarray:
        """Entry parameter ``t`` of each ray, ``+inf`` where it misses."""
        ox, oy, oz = origin
        dx, dy, dz = direction
        px, py, pz = ox - self.x, oy - self.y, oz - self.z
        a = dx * dx + dy * dy + dz * dz
        b = 2.0 * (dx * px + dy * py + dz * pz)
        c = px * px + py * py + pz * pz - self.radius_m ** 2
        disc = b * b - 4.0 * a * c
        t = (-b - np.sqrt(np.maximum(disc, 0.0))) / (2.0 * a)
        return np.where((disc >= 0) & (t > eps), t, np.inf)

    def normal(self, point: Vec3) -> Vec3:
        """Outward unit normal."""
        x, y, z = point
        r = self.radius_m
        return (x - self.x) / r, (y - self.y) / r, (z - self.z) / r

    def surface_uv(self, point: Vec3, normal: Vec3) -> tuple[np.ndarray, np.ndarray]:
        """Texture coordinates in metres (a planar projection, adequate for foliage)."""
        x, y, z = point
        return x + 0.5 * y, z + 0.5 * y


Primitive = Box | Cylinder | Sphere
"""Any solid shape of the synthetic world."""


def bounding_corners(primitive: Primitive) -> np.ndarray:
    """The 8 corners of the primitive's axis-aligned bounding box, ``(8, 3)`` metres."""
    lo, hi = primitive.bounds()
    return np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
