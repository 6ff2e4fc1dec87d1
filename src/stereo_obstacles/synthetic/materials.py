"""Named surface materials: procedural colour textures defined in world coordinates.

A :class:`Material` is a recipe (base and alternate colour as linear RGB albedo in [0, 1],
a pattern, the pattern's cell size in metres and a texture contrast). Its texture is built
once per process from a fixed seed derived from the recipe, so the same material looks
the same in every scene, in both cameras and in every frame of a sequence. The albedo at a
surface point is ``detail(s, t) * macro(s, t)``: a fine tiling detail texture (a few metres
of period) times a coarse brightness/colour variation with an unrelated period, so that no
repetition is visible and stereo cannot lock onto a repeated copy.

Ground materials: ``pavement`` (concrete flagstones with joints), ``asphalt``, ``grass`` and
``tiles`` (small paving bricks in running bond). Obstacle materials are in
:data:`MATERIALS`; :func:`dark_variant` makes the hard case of an obstacle with the ground's
hue, only darker.
"""

from __future__ import annotations

import functools
import math
import zlib
from dataclasses import dataclass, replace

import numpy as np

from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.synthetic.textures import MipTexture, periodic_noise

PATTERNS = ("speckle", "slabs", "pavers", "grass", "brick", "plain", "foliage")
"""Texture patterns a material can use."""

_DETAIL_SIZE = 512
_MACRO_SIZE = 128
_MACRO_TEXEL_M = 0.061
"""Macro texture: 128 texels of 6.1 cm, a period of 7.8 m (unrelated to any detail period).
Its finest features span about 6 texels (37 cm), more than a pixel's footprint up to about
100 m away, so it is looked up without a pyramid."""


@dataclass(frozen=True)
class Material:
    """A surface recipe.

    Attributes
    ----------
    name : str
        Identifier used in scene files.
    colour_name : str
        Plain-language colour for reports ("red", "dark grey-beige", ...).
    rgb, alt_rgb : tuple of 3 floats
        Linear albedo of the main colour and of the colour it varies towards, in [0, 1].
    pattern : str
        One of :data:`PATTERNS`.
    cell_m : float
        Pattern cell in metres (slab, paver or brick length; texel size for the others).
    contrast : float
        Strength of the fine luminance texture (0 = flat colour).
    """

    name: str
    colour_name: str
    rgb: tuple[float, float, float]
    alt_rgb: tuple[float, float, float]
    pattern: str
    cell_m: float
    contrast: float = 0.25

    def __post_init__(self) -> None:
        if self.pattern not in PATTERNS:
            raise InvalidInputError(f"material pattern must be one of {PATTERNS}, got {self.pattern!r}")
        for field in ("rgb", "alt_rgb"):
            value = tuple(float(c) for c in getattr(self, field))
            if len(value) != 3 or not all(0.0 <= c <= 1.0 for c in value):
                raise InvalidInputError(f"material {field} must be 3 values in [0, 1], got {value}")
            object.__setattr__(self, field, value)
        if not (math.isfinite(self.cell_m) and self.cell_m > 0):
            raise InvalidInputError(f"material cell_m must be > 0 metres, got {self.cell_m}")
        if not (math.isfinite(self.contrast) and 0.0 <= self.contrast <= 1.0):
            raise InvalidInputError(f"material contrast must be in [0, 1], got {self.contrast}")

    def albedo(self, s_m: np.ndarray, t_m: np.ndarray, footprint_m: np.ndarray) -> np.ndarray:
        """Linear RGB albedo ``(N, 3)`` at texture coordinates ``(s, t)`` metres.

        ``footprint_m`` is the size of a sample's footprint on the surface (metres), which
        selects the texture detail that survives in the picture.
        """
        detail, macro = _textures(self)
        return detail.sample(s_m, t_m, footprint_m) * macro.sample(s_m, t_m, footprint_m)


def _rng(material: Material, salt: str) -> np.random.Generator:
    return np.random.default_rng(zlib.crc32(f"{material.name}/{salt}".encode()))


def _mix(a: tuple[float, ...], b: tuple[float, ...], m: np.ndarray) -> np.ndarray:
    a_, b_ = np.asarray(a, np.float32), np.asarray(b, np.float32)
    return a_ + (b_ - a_) * m[..., None]


def _sigmoid(x: np.ndarray) -> np.ndarray:
    return 1.0 / (1.0 + np.exp(-x))


def _cells(size: int, cells_x: int, cells_y: int, offset_rows: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Cell index and distance to the nearest cell edge (texels) on a tiling grid."""
    yy, xx = np.mgrid[0:size, 0:size].astype(np.float64) + 0.5
    cw, ch = size / cells_x, size / cells_y
    row = np.floor(yy / ch)
    shift = np.where(offset_rows & (row % 2 == 1), cw / 2.0, 0.0)
    xs = np.mod(xx + shift, size)
    col = np.floor(xs / cw)
    edge = np.minimum(np.minimum(xs - col * cw, (col + 1) * cw - xs),
                      np.minimum(yy - row * ch, (row + 1) * ch - yy))
    cell_id = (row * cells_x + col).astype(np.int64)
    return cell_id, edge, row


def _detail_image(material: Material) -> tuple[np.ndarray, float]:
    """The detail albedo image and its texel size in metres."""
    rng = _rng(material, "detail")
    n = _DETAIL_SIZE
    p = material.pattern
    grain = 0.5 * periodic_noise(rng, n, 2.0) + 0.35 * periodic_noise(rng, n, 5.0) \
        + 0.25 * periodic_noise(rng, n, 14.0)
    blend = _sigmoid(1.5 * periodic_noise(rng, n, 60.0))
    texel = material.cell_m
    if p == "slabs":
        cells = 4
        texel = material.cell_m * cells / n
        cell_id, edge, _ = _cells(n, cells, cells, offset_rows=False)
        tint = 1.0 + 0.08 * rng.standard_normal(cells * cells)[cell_id]
        joint = np.clip(edge / 2.0, 0.0, 1.0)
        lum = tint * (1.0 + material.contrast * grain) * (0.45 + 0.55 * joint)
    elif p == "pavers":
        cells_x, cells_y = 8, 16
        texel = material.cell_m * cells_x / n
        cell_id, edge, _ = _cells(n, cells_x, cells_y, offset_rows=True)
        blend = rng.uniform(0.0, 1.0, cells_x * cells_y)[cell_id] ** 1.5
        tint = 1.0 + 0.12 * rng.standard_normal(cells_x * cells_y)[cell_id]
        grout = np.clip((edge - 1.0) / 2.0, 0.0, 1.0)
        lum = tint * (1.0 + material.contrast * grain) * (0.35 + 0.65 * grout)
    elif p == "brick":
        cells_x, cells_y = 4, 16
        texel = material.cell_m * cells_x / n
        cell_id, edge, _ = _cells(n, cells_x, cells_y, offset_rows=True)
        blend = rng.uniform(0.0, 1.0, cells_x * cells_y)[cell_id]
        mortar = np.clip((edge - 1.5) / 1.5, 0.0, 1.0)
        lum = (1.0 + material.contrast * grain) * (0.9 + 0.1 * mortar)
        blend = np.where(mortar < 0.5, 1.0, blend * 0.6)
    elif p == "speckle":
        stones = periodic_noise(rng, n, 3.0)
        lum = (1.0 + material.contrast * grain) * (1.0 + 0.35 * np.clip(stones - 1.4, 0.0, 1.0))
    elif p == "grass":
        blades = periodic_noise(rng, n, 1.5) + 0.6 * periodic_noise(rng, n, 4.0)
        lum = np.clip(1.0 + material.contrast * blades, 0.2, 2.0)
        blend = _sigmoid(2.0 * periodic_noise(rng, n, 40.0) + 0.8 * blades)
    elif p == "foliage":
        lum = np.clip(1.0 + material.contrast * (periodic_noise(rng, n, 6.0) + grain), 0.1, 2.0)
    else:  # plain: paint or plastic with faint wear, enough for stereo to match
        lum = 1.0 + material.contrast * (0.6 * grain + 0.4 * periodic_noise(rng, n, 30.0))
    image = _mix(material.rgb, material.alt_rgb, blend) * np.maximum(lum, 0.0)[..., None]
    return np.clip(image, 0.0, 1.0).astype(np.float32), texel


@functools.lru_cache(maxsize=64)
def _textures(material: Material) -> tuple[MipTexture, MipTexture]:
    image, texel = _detail_image(material)
    rng = _rng(material, "macro")
    variation = 0.6 * periodic_noise(rng, _MACRO_SIZE, 20.0) + 0.4 * periodic_noise(rng, _MACRO_SIZE, 6.0)
    macro = (1.0 + 0.12 * variation)[..., None] * np.ones(3, np.float32)
    return MipTexture.from_image(image, texel), MipTexture.from_image(macro.astype(np.float32), _MACRO_TEXEL_M,
                                                                          max_levels=1)


def _m(name: str, colour: str, rgb: tuple, alt: tuple, pattern: str, cell: float, contrast: float = 0.25
       ) -> Material:
    return Material(name, colour, rgb, alt, pattern, cell, contrast)


GROUND_MATERIALS: dict[str, Material] = {
    "pavement": _m("pavement", "light grey-beige", (0.32, 0.28, 0.225), (0.26, 0.25, 0.235), "slabs", 0.6, 0.22),
    "asphalt": _m("asphalt", "dark grey", (0.085, 0.083, 0.08), (0.10, 0.095, 0.088), "speckle", 0.002, 0.35),
    "grass": _m("grass", "green", (0.05, 0.14, 0.025), (0.15, 0.19, 0.05), "grass", 0.003, 0.45),
    "tiles": _m("tiles", "red-brown", (0.30, 0.11, 0.07), (0.20, 0.16, 0.14), "pavers", 0.2, 0.2),
}
"""The ground surfaces a scene can stand on."""

MATERIALS: dict[str, Material] = {
    **GROUND_MATERIALS,
    "cardboard": _m("cardboard", "brown", (0.36, 0.22, 0.11), (0.30, 0.19, 0.10), "plain", 0.003, 0.15),
    "red_plastic": _m("red_plastic", "red", (0.50, 0.05, 0.04), (0.42, 0.04, 0.04), "plain", 0.003, 0.1),
    "blue_plastic": _m("blue_plastic", "blue", (0.04, 0.11, 0.40), (0.05, 0.14, 0.36), "plain", 0.003, 0.1),
    "yellow_paint": _m("yellow_paint", "yellow", (0.62, 0.46, 0.04), (0.55, 0.42, 0.06), "plain", 0.003, 0.12),
    "green_paint": _m("green_paint", "green", (0.04, 0.22, 0.08), (0.05, 0.18, 0.07), "plain", 0.003, 0.12),
    "metal": _m("metal", "grey", (0.33, 0.34, 0.36), (0.28, 0.29, 0.31), "plain", 0.002, 0.08),
    "concrete": _m("concrete", "light grey", (0.42, 0.41, 0.39), (0.36, 0.36, 0.35), "speckle", 0.002, 0.2),
    "brick": _m("brick", "brick red", (0.32, 0.11, 0.06), (0.40, 0.39, 0.36), "brick", 0.215, 0.2),
    "white_paint": _m("white_paint", "white", (0.70, 0.70, 0.66), (0.55, 0.55, 0.52), "plain", 0.003, 0.15),
    "yellow_line": _m("yellow_line", "yellow", (0.70, 0.50, 0.05), (0.55, 0.42, 0.08), "plain", 0.003, 0.15),
    "bark": _m("bark", "dark brown", (0.12, 0.08, 0.05), (0.08, 0.06, 0.04), "speckle", 0.004, 0.4),
    "foliage": _m("foliage", "dark green", (0.05, 0.12, 0.03), (0.09, 0.14, 0.03), "foliage", 0.01, 0.5),
}
"""Every named material (ground materials included)."""

OBSTACLE_MATERIALS = ("cardboard", "red_plastic", "blue_plastic", "yellow_paint", "green_paint",
                      "metal", "concrete", "brick")
"""Materials random scenes draw obstacles from."""


def material(name: str) -> Material:
    """The named material; raise :class:`InvalidInputError` for an unknown name."""
    try:
        return MATERIALS[name]
    except KeyError:
        raise InvalidInputError(f"unknown material {name!r}; known: {', '.join(sorted(MATERIALS))}") from None


def ground_material(name: str) -> Material:
    """The named ground material (one of :data:`GROUND_MATERIALS`)."""
    if name not in GROUND_MATERIALS:
        raise InvalidInputError(f"ground must be one of {', '.join(GROUND_MATERIALS)}, got {name!r}")
    return GROUND_MATERIALS[name]


def dark_variant(ground: Material, factor: float = 0.45) -> Material:
    """An obstacle material with the ground's hue and texture, ``factor`` times as bright.

    The hard case of shadow-robust segmentation: hue-wise it looks like shadowed ground.
    """
    return replace(ground, name=f"dark_{ground.name}", colour_name=f"dark {ground.colour_name}",
                   rgb=tuple(c * factor for c in ground.rgb), alt_rgb=tuple(c * factor for c in ground.alt_rgb),
                   pattern="speckle" if ground.pattern in ("slabs", "pavers") else ground.pattern,
                   cell_m=0.003)
