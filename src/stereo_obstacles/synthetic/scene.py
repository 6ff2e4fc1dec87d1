"""What a synthetic scene is made of: obstacles, ground markings, the sun and sky, the rig.

Everything is in the world frame of :mod:`stereo_obstacles.synthetic.primitives` (metres,
``x`` right, ``y`` forward, ``z`` up, ground ``z = 0``, origin on the ground below the
left camera at the start of a sequence).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import plain_numbers
from stereo_obstacles.synthetic.materials import Material
from stereo_obstacles.synthetic.primitives import Box, Cylinder, Primitive, Sphere
from stereo_obstacles.synthetic.rig import StereoRig

OBSTACLE_KINDS = ("box", "pole", "cylinder", "wall", "tree")
"""Kinds of solid objects; ``tree`` (trunk and canopy) is used as an off-screen shadow caster."""


@dataclass(frozen=True)
class Obstacle:
    """A solid object standing on the ground.

    Attributes
    ----------
    obstacle_id : int
        1..255; the value of its pixels in the instance image.
    kind : str
        One of :data:`OBSTACLE_KINDS`.
    primitives : tuple
        The solid shapes it is made of.
    material : Material
        Surface of its main part (for a tree: the trunk).
    extra_material : Material or None
        Surface of the further primitives (a tree's canopy), ``None`` when they share ``material``.
    """

    obstacle_id: int
    kind: str
    primitives: tuple[Primitive, ...]
    material: Material
    extra_material: Material | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.obstacle_id, int) or not 1 <= self.obstacle_id <= 255:
            raise InvalidInputError(f"obstacle_id must be an integer in [1, 255], got {self.obstacle_id!r}")
        if self.kind not in OBSTACLE_KINDS:
            raise InvalidInputError(f"obstacle kind must be one of {OBSTACLE_KINDS}, got {self.kind!r}")
        if not self.primitives or not all(isinstance(p, (Box, Cylinder, Sphere)) for p in self.primitives):
            raise InvalidInputError("an obstacle needs at least one Box, Cylinder or Sphere")

    def material_of(self, index: int) -> Material:
        """Material of the ``index``-th primitive."""
        return self.material if index == 0 or self.extra_material is None else self.extra_material

    def bounds(self) -> np.ndarray:
        """``(2, 3)`` axis-aligned bounding box (min and max corner) in world metres."""
        b = np.stack([p.bounds() for p in self.primitives])
        return np.stack([b[:, 0].min(axis=0), b[:, 1].max(axis=0)])


@dataclass(frozen=True)
class Marking:
    """A flat painted rectangle on the ground (a line, a crossing bar).

    Attributes
    ----------
    x, y : float
        Centre on the ground, metres.
    length_m, width_m : float
        Size along and across its direction.
    angle_deg : float
        Direction of its length, degrees counter-clockwise from world ``+y`` (forward).
    material : Material
        Paint.
    """

    x: float
    y: float
    length_m: float
    width_m: float
    angle_deg: float
    material: Material

    def __post_init__(self) -> None:
        for name in ("x", "y", "angle_deg"):
            if not math.isfinite(getattr(self, name)):
                raise InvalidInputError(f"marking {name} must be finite, got {getattr(self, name)}")
        for name in ("length_m", "width_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise InvalidInputError(f"marking {name} must be > 0 metres, got {value}")

    def contains(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """True where the ground point ``(x, y)`` is painted."""
        a = math.radians(self.angle_deg)
        along_x, along_y = -math.sin(a), math.cos(a)
        dx, dy = x - self.x, y - self.y
        along = dx * along_x + dy * along_y
        across = dx * along_y - dy * along_x
        return (np.abs(along) <= self.length_m / 2) & (np.abs(across) <= self.width_m / 2)


@dataclass(frozen=True)
class Lighting:
    """Sun and sky.

    Attributes
    ----------
    sun_azimuth_deg : float
        Compass direction the sunlight comes from: 0 ahead (+y), 90 right (+x), 180 behind.
    sun_elevation_deg : float
        Height of the sun above the horizon, degrees (5..89).
    sun_irradiance_rgb : tuple of 3 floats
        Direct sunlight on a surface facing the sun (linear units).
    sky_irradiance_rgb : tuple of 3 floats
        Bluish diffuse skylight on an upward-facing surface (linear units).
    """

    sun_azimuth_deg: float = 250.0
    sun_elevation_deg: float = 35.0
    sun_irradiance_rgb: tuple[float, float, float] = (1.0, 0.93, 0.82)
    sky_irradiance_rgb: tuple[float, float, float] = (0.26, 0.33, 0.48)

    def __post_init__(self) -> None:
        plain_numbers(self)                      # NumPy scalars as Python numbers (JSON-ready)
        if not math.isfinite(self.sun_azimuth_deg):
            raise InvalidInputError(f"sun_azimuth_deg must be finite, got {self.sun_azimuth_deg}")
        if not (math.isfinite(self.sun_elevation_deg) and 5.0 <= self.sun_elevation_deg <= 89.0):
            raise InvalidInputError(f"sun_elevation_deg must be in [5, 89], got {self.sun_elevation_deg}")
        for name in ("sun_irradiance_rgb", "sky_irradiance_rgb"):
            value = tuple(float(c) for c in getattr(self, name))
            if len(value) != 3 or not all(math.isfinite(c) and c >= 0 for c in value):
                raise InvalidInputError(f"{name} must be 3 values >= 0, got {value}")
            object.__setattr__(self, name, value)

    def sun_direction(self) -> np.ndarray:
        """Unit vector from a surface point towards the sun, world frame."""
        az, el = math.radians(self.sun_azimuth_deg), math.radians(self.sun_elevation_deg)
        return np.array([math.sin(az) * math.cos(el), math.cos(az) * math.cos(el), math.sin(el)])


@dataclass(frozen=True)
class Scene:
    """A complete synthetic world: rig, ground, obstacles, markings, light.

    Attributes
    ----------
    rig : StereoRig
        The cameras.
    ground : Material
        Surface of the ground plane.
    obstacles : tuple of Obstacle
        Solid objects, including off-screen shadow casters.
    markings : tuple of Marking
        Flat paint on the ground.
    lighting : Lighting
        Sun and sky.
    seed : int
        The seed the scene was generated from (also seeds the sensor noise).
    description : dict
        Generation parameters, recorded in ``scene.json``.
    """

    rig: StereoRig
    ground: Material
    obstacles: tuple[Obstacle, ...]
    markings: tuple[Marking, ...] = ()
    lighting: Lighting = field(default_factory=Lighting)
    seed: int = 0
    description: dict = field(default_factory=dict, compare=False, hash=False)

    def __post_init__(self) -> None:
        ids = [o.obstacle_id for o in self.obstacles]
        if len(set(ids)) != len(ids):
            raise InvalidInputError(f"obstacle ids must be unique, got {ids}")
        if not isinstance(self.seed, int) or self.seed < 0:
            raise InvalidInputError(f"scene seed must be an integer >= 0, got {self.seed!r}")

    def primitives(self) -> list[tuple[Primitive, int, Material]]:
        """Every solid shape with its owner's ``obstacle_id`` and its material."""
        return [(p, o.obstacle_id, o.material_of(i)) for o in self.obstacles for i, p in enumerate(o.primitives)]

    def to_dict(self) -> dict:
        """JSON-ready description of the whole scene (geometry, materials, light, rig)."""
        def material_dict(m: Material | None) -> dict | None:
            return None if m is None else asdict(m)

        return {
            "seed": self.seed,
            "rig": asdict(self.rig),
            "ground": material_dict(self.ground),
            "lighting": asdict(self.lighting),
            "obstacles": [{"id": o.obstacle_id, "kind": o.kind, "material": material_dict(o.material),
                           "extra_material": material_dict(o.extra_material),
                           "primitives": [{"shape": type(p).__name__.lower(), **asdict(p)} for p in o.primitives]}
                          for o in self.obstacles],
            "markings": [{**{k: v for k, v in asdict(m).items() if k != "material"},
                          "material": material_dict(m.material)} for m in self.markings],
            "generation": dict(self.description),
        }
