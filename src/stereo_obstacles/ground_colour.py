"""A ground colour model that survives cast shadows: reference colours and their relit versions.

The paper describes the ground by one mean hue and an intensity range. Measured on the
synthetic scenes (docs/segmentation.md) that fails three ways: two-colour ground (pavers)
is not one hue; a shadow under blue skylight shifts the hue of weakly coloured ground by tens
of degrees; and an obstacle standing in the reference rectangle moves its statistics. This
model instead keeps the **set** of ground colours and predicts what that ground looks like in
shadow:

* Colours are cells of a 3-D grid over ``log(channel + offset)`` (``bin`` natural-log units
  wide, ``offset`` a fraction of full scale that keeps sensor noise in dark pixels from
  spreading over many cells). A change of light multiplies each channel by a factor, so in
  this space it is a **shift**, the same for every ground colour (both colours of a paver).
* Reference colours are sampled from ``n_strips`` side-by-side strips of the reference area,
  at the pixel scale and after box means over ``texture_scales_px`` (far ground averages
  its texture). A cell counts as ground only when at least ``quorum`` strips hold at least
  ``min_count`` samples in it: the ground runs across the whole bottom of the picture, an
  obstacle standing in the area usually covers only some strips.
* Shadow cells are the ground cells shifted by every skylight shift
  ``(u (1 + k / 2), u, u (1 - k / 2))`` with ``log(alpha) <= u <= log(beta)`` (the
  paper's "darker", bounded as in shadow detectors: ``alpha <= I / I_ref <= beta``) and
  blueness ``min_blueness <= k <= max_blueness``: a cast shadow keeps only the bluish
  skylight, so its red falls more than its blue. A dark obstacle of the ground's own colour
  darkens all channels alike (``k = 0``) and is not a shadow. Optionally
  (``min_shadow_chroma_bins``) the weakest shifts, whose rounded chroma change is too small
  to tell them from such a grey darkening, are dropped.
* Sunlit cells are the reverse shifts (the reference itself lies in a shadow).
* Optionally (``shift_chroma_radius_bins``), one shift per image: one sun and one sky light
  a flat ground, so the shift that the image supports best (the most pixels in the ground
  colours shifted by it, darker or brighter) is kept with its neighbours within
  ``shift_chroma_radius_bins`` and ``shift_brightness_radius_bins``, and the rest of the
  family, which would only take in obstacles whose colour happens to be another relit ground
  colour, is dropped. Real shadows (tree canopies, penumbra) spread over several shifts, so
  the default keeps the whole family.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import cv2
import numpy as np

from stereo_obstacles._ground_colour_kernel import (GROUND_BIT, SHADOW_BIT, SUNLIT_BIT,
                                                    colour_histogram_kernel, fill_table_kernel,
                                                    ground_cells_kernel, lookup_kernel,
                                                    shift_support_kernel)
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import plain_numbers


@dataclass(frozen=True)
class GroundColourParameters:
    """Thresholds of the ground colour model (defaults measured in docs/segmentation.md).

    Attributes
    ----------
    bin
        Cell width in natural-log units of a channel (0.05: a 5 % change).
    offset
        Added to every channel before the logarithm, fraction of full scale.
    n_strips, quorum
        The reference area is cut into ``n_strips`` vertical strips; a colour is ground when
        ``quorum`` of them show it.
    min_count
        Samples a strip needs in a cell to show that colour.
    texture_scales_px
        Sample the reference at these box-mean sizes, pixels (1 = the pixels themselves).
    min_blueness, max_blueness
        Bounds of ``k``: how much more the red than the blue log-channel falls, per unit of
        darkening (0: a grey darkening; skylight shadows measure about 0.45..0.6).
    green_tolerance_bins
        The green log-channel of a shadow may fall this many cells more or less than the
        middle of red and blue (skylight is not exactly symmetric in green).
    shift_chroma_radius_bins, shift_brightness_radius_bins
        Keep only the shadow (and sunlit) shifts whose chroma (red and blue relative to green)
        is within the first and whose green is within the second number of cells of the shift
        the image supports best (penumbra and partly hidden sky vary a shadow's darkness more
        than its colour); a chroma radius of ``None`` (the default) keeps the whole family, and
        the brightness radius (default 2) then plays no part. ``2`` and ``2``
        measured better on synthetic scenes (held-out BER 17.6 -> 16.0 %) but called twice as
        much shadowed KITTI road an obstacle (7.0 -> 14.4 %; docs/segmentation.md), so the
        single shift is an option, not the default.
    support_step_px
        The support of each shift is counted on every this-many-th row and column.
    min_shadow_chroma_bins
        Drop the skylight shifts (and their sunlit reverses) that move blue against red by
        fewer than this many cells: at weak darkening (``u`` near ``log 0.8``) the rounded
        skylight shift is within one cell of a grey darkening, so a ground-coloured obstacle
        darkened alike in all channels (``k = 0``) reads as shadow. ``0`` (the default) keeps
        the whole family; ``2`` drops the one shift ``(-5, -4, -4)`` of the default family and
        measured held-out BER 17.56 -> 17.12 % but KITTI road -> obstacle 6.96 -> 7.87 %
        (docs/segmentation.md), so it is an option.
    """

    bin: float = 0.05
    offset: float = 0.03
    n_strips: int = 7
    quorum: int = 4
    min_count: int = 2
    texture_scales_px: tuple[int, ...] = (1, 5)
    min_blueness: float = 0.4
    max_blueness: float = 0.7
    green_tolerance_bins: int = 0
    shift_chroma_radius_bins: int | None = None
    shift_brightness_radius_bins: int = 2
    support_step_px: int = 2
    min_shadow_chroma_bins: int = 0

    def __post_init__(self) -> None:
        plain_numbers(self)                      # NumPy scalars as Python numbers (JSON-ready)
        if not (math.isfinite(self.bin) and 0.005 <= self.bin <= 0.5):
            raise InvalidInputError(f"bin must be in [0.005, 0.5] log units, got {self.bin!r}")
        if not (math.isfinite(self.offset) and 0.001 <= self.offset <= 0.5):
            raise InvalidInputError(f"offset must be in [0.001, 0.5] of full scale, got {self.offset!r}")
        if (isinstance(self.green_tolerance_bins, bool) or not isinstance(self.green_tolerance_bins, int)
                or not 0 <= self.green_tolerance_bins <= 5):
            raise InvalidInputError(f"green_tolerance_bins must be an integer in [0, 5], got "
                                    f"{self.green_tolerance_bins!r}")
        if (isinstance(self.min_shadow_chroma_bins, bool) or not isinstance(self.min_shadow_chroma_bins, int)
                or not 0 <= self.min_shadow_chroma_bins <= 40):
            raise InvalidInputError(f"min_shadow_chroma_bins must be an integer in [0, 40], got "
                                    f"{self.min_shadow_chroma_bins!r}")
        for name in ("shift_chroma_radius_bins", "shift_brightness_radius_bins"):
            radius = getattr(self, name)
            if (radius is not None or name == "shift_brightness_radius_bins") and (
                    isinstance(radius, bool) or not isinstance(radius, int) or not 0 <= radius <= 40):
                raise InvalidInputError(f"{name} must be an integer in [0, 40], got {radius!r}")
        for name in ("n_strips", "quorum", "min_count", "support_step_px"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= 255:
                raise InvalidInputError(f"{name} must be an integer in [1, 255], got {value!r}")
        if self.quorum > self.n_strips:
            raise InvalidInputError(f"quorum ({self.quorum}) must not exceed n_strips ({self.n_strips})")
        scales = self.texture_scales_px
        if (not isinstance(scales, tuple) or not scales
                or any(isinstance(k, bool) or not isinstance(k, int) or k < 1 for k in scales)):
            raise InvalidInputError(f"texture_scales_px must be a tuple of positive integers, got {scales!r}")
        if not (math.isfinite(self.min_blueness) and math.isfinite(self.max_blueness)
                and 0.0 <= self.min_blueness <= self.max_blueness < 2.0):
            raise InvalidInputError("need 0 <= min_blueness <= max_blueness < 2, got "
                                    f"{self.min_blueness!r} and {self.max_blueness!r}")


@functools.lru_cache(maxsize=8)
def _bin_lut(full_scale: int, offset: float, bin_width: float) -> tuple[np.ndarray, int]:
    values = np.arange(full_scale + 1, dtype=np.float64) / full_scale
    lut = np.floor((np.log(values + offset) - math.log(offset)) / bin_width).astype(np.int32)
    lut.setflags(write=False)
    return lut, int(lut[-1]) + 1


@functools.lru_cache(maxsize=8)
def shadow_shifts(params: GroundColourParameters, shadow_ratio: tuple[float, float] | None
                  ) -> np.ndarray:
    """Cell shifts of the model: ``int32 (K, 4)`` rows ``(dr, dg, db, bit)``.

    Row 0 is the identity (``GROUND_BIT``). With ``shadow_ratio = (alpha, beta)``, the
    brightness ratio bounds of a shadow (``0 < alpha < beta < 1``), the skylight shifts
    (``SHADOW_BIT``) and their reverses (``SUNLIT_BIT``) follow, each distinct shift once;
    ``None`` is the ablation without the shadow rule. Shadow shifts that lower red by fewer
    than ``params.min_shadow_chroma_bins`` cells more than blue are left out, with their
    reverses. Cached: the result is read-only.
    """
    rows = {(0, 0, 0, GROUND_BIT): None}
    if shadow_ratio is not None:
        low, high = (math.log(v) for v in shadow_ratio)
        if not low < high < 0.0:
            raise InvalidInputError(f"shadow_ratio must be (alpha, beta) with 0 < alpha < beta < 1, "
                                    f"got {shadow_ratio!r}")
        steps = max(2, int(math.ceil((high - low) / params.bin)) + 1)
        for u in np.linspace(low, high, steps):
            for k in np.linspace(params.min_blueness, params.max_blueness, 4):
                shift = np.rint(np.array([u * (1 + k / 2), u, u * (1 - k / 2)]) / params.bin).astype(int)
                if shift[2] - shift[0] < params.min_shadow_chroma_bins:
                    continue
                for green in range(-params.green_tolerance_bins, params.green_tolerance_bins + 1):
                    moved = shift + np.array([0, green, 0])
                    rows[(*moved, SHADOW_BIT)] = None
                    rows[(*(-moved), SUNLIT_BIT)] = None
    shifts = np.array(list(rows), dtype=np.int32)
    shifts.setflags(write=False)
    return shifts


def select_shifts(shifts: np.ndarray, support: np.ndarray, chroma_radius_bins: int,
                  brightness_radius_bins: int) -> np.ndarray:
    """Keep the identity and the shifts near the image's own shadow shift.

    Parameters
    ----------
    shifts
        ``int32 (K, 4)`` from :func:`shadow_shifts` (row 0 the identity).
    support
        ``(K,)``: image pixels in the ground colours moved by each row.
    chroma_radius_bins, brightness_radius_bins
        How far, in cells, a kept shift's chroma (red and blue relative to green) and its
        green (brightness) may differ from those of the best shift.

    Returns
    -------
    numpy.ndarray
        The rows of ``shifts`` kept: the identity, the shadow shifts near ``s``, and the
        sunlit shifts near ``-s``, where ``s`` is the shadow shift with the largest support of
        ``s`` and ``-s`` together.

    Examples
    --------
    >>> shifts = np.array([[0, 0, 0, 1], [-4, -3, -2, 2], [4, 3, 2, 4], [-9, -7, -5, 2], [9, 7, 5, 4]])
    >>> select_shifts(shifts, np.array([0, 5, 90, 10, 0]), 1, 2)[:, 3].tolist()
    [1, 2, 4]
    """
    offsets = shifts[:, :3]
    bits = shifts[:, 3]
    score = {tuple(row): 0 for row in offsets[bits == SHADOW_BIT]}
    for row, bit, count in zip(offsets, bits, support):
        if bit == SHADOW_BIT and tuple(row) in score:
            score[tuple(row)] += int(count)
        elif bit == SUNLIT_BIT and tuple(-row) in score:
            score[tuple(-row)] += int(count)
    if not score:
        return shifts
    best = np.array(max(score, key=score.get))
    chroma = offsets - offsets[:, 1:2]
    best_chroma = best - best[1]
    near_shadow = ((np.abs(chroma - best_chroma).max(axis=1) <= chroma_radius_bins)
                   & (np.abs(offsets[:, 1] - best[1]) <= brightness_radius_bins))
    near_sunlit = ((np.abs(chroma + best_chroma).max(axis=1) <= chroma_radius_bins)
                   & (np.abs(offsets[:, 1] + best[1]) <= brightness_radius_bins))
    keep = ((bits == GROUND_BIT) | ((bits == SHADOW_BIT) & near_shadow)
            | ((bits == SUNLIT_BIT) & near_sunlit))
    return shifts[keep]


@dataclass(frozen=True, eq=False)
class GroundColourModel:
    """Ground, shadow and sunlit colours as bits of a 3-D table over quantised log channels.

    Attributes
    ----------
    table
        ``uint8 (n, n, n)`` cell bits (``_ground_colour_kernel`` constants).
    lut
        ``int32 (full_scale + 1,)``: channel value -> cell index.
    n_ground_cells
        Cells accepted as ground colours (0 means the reference showed no consistent ground).
    shifts
        ``int32 (K, 4)`` the shifts the table was built with (:func:`shadow_shifts`, reduced
        to the image's own shadow shift and its neighbours, :func:`select_shifts`).
    params
        The parameters used.
    """

    table: np.ndarray
    lut: np.ndarray
    n_ground_cells: int
    shifts: np.ndarray
    params: GroundColourParameters

    def __post_init__(self) -> None:
        n = self.table.shape[0]
        if self.table.dtype != np.uint8 or self.table.shape != (n, n, n):
            raise InvalidInputError(f"table must be uint8 (n, n, n), got {self.table.dtype} {self.table.shape}")
        if self.lut.ndim != 1 or int(self.lut.max()) >= n or int(self.lut.min()) < 0:
            raise InvalidInputError("lut must map channel values into the table")


def build_ground_colour_model(rgb: np.ndarray, box_px: tuple[int, int, int, int], *,
                              params: GroundColourParameters = GroundColourParameters(),
                              shadow_ratio: tuple[float, float] | None = (0.4, 0.8)
                              ) -> GroundColourModel:
    """Learn the ground colours from the reference area ``box_px`` of ``rgb``.

    Parameters
    ----------
    rgb
        ``uint8``/``uint16 (H, W, 3)`` C-contiguous image.
    box_px
        ``(x0, y0, x1, y1)`` half-open reference area in pixels, at least ``n_strips`` wide.
    params
        Model thresholds.
    shadow_ratio
        ``(alpha, beta)``: a shadow is ``alpha..beta`` times as bright as lit ground; None
        leaves shadows out of the model (the ablation of the paper's Figs. 13-14).

    Returns
    -------
    GroundColourModel

    Raises
    ------
    InvalidInputError
        The area is narrower than the number of strips.
    """
    x0, y0, x1, y1 = box_px
    if x1 - x0 < params.n_strips or y1 <= y0:
        raise InvalidInputError(f"reference area {box_px} must be at least {params.n_strips} px wide "
                                "(one column per strip)")
    full_scale = int(np.iinfo(rgb.dtype).max)
    lut, n_bins = _bin_lut(full_scale, float(params.offset), float(params.bin))
    edges = np.linspace(x0, x1, params.n_strips + 1).round().astype(int)
    area = rgb[y0:y1, x0:x1]
    samples = np.empty((len(params.texture_scales_px),) + area.shape, dtype=rgb.dtype)
    for i, k in enumerate(params.texture_scales_px):
        for a, b in zip(edges[:-1] - x0, edges[1:] - x0):
            strip = area[:, a:b]
            samples[i, :, a:b] = strip if k == 1 else cv2.blur(strip, (k, k), borderType=cv2.BORDER_REFLECT)
    column_strip = np.repeat(np.arange(params.n_strips, dtype=np.int32), np.diff(edges))
    ground = ground_cells_kernel(samples, lut, column_strip, params.n_strips, params.quorum,
                                 params.min_count, n_bins)
    shifts = shadow_shifts(params, None if shadow_ratio is None else tuple(float(v) for v in shadow_ratio))
    if params.shift_chroma_radius_bins is not None and shifts.shape[0] > 1:
        histogram = colour_histogram_kernel(rgb, lut, n_bins, params.support_step_px)
        shifts = select_shifts(shifts, shift_support_kernel(ground, histogram, n_bins, shifts),
                               params.shift_chroma_radius_bins, params.shift_brightness_radius_bins)
    table = np.zeros((n_bins, n_bins, n_bins), dtype=np.uint8)
    fill_table_kernel(ground, n_bins, shifts, table)
    n_ground = int(ground.shape[0])
    return GroundColourModel(table=table, lut=lut, n_ground_cells=n_ground, shifts=shifts, params=params)


def colour_flags(rgb: np.ndarray, model: GroundColourModel, min_intensity: float
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Per-pixel colour tests of an image against the model.

    Parameters
    ----------
    rgb
        ``uint8``/``uint16 (H, W, 3)`` C-contiguous image of the dtype the model was built for.
    model
        From :func:`build_ground_colour_model`.
    min_intensity
        Pixels with ``(R + G + B) / 3`` below this fraction of full scale are not measurable.

    Returns
    -------
    flags : numpy.ndarray
        ``uint8 (H, W, 4)`` 0/1: ground colour, shadow colour, sunlit colour, measurable.
    veto : numpy.ndarray
        ``bool (H, W)``: the colour is not within one cell of any model colour.
    """
    if model.lut.shape[0] != int(np.iinfo(rgb.dtype).max) + 1:
        raise InvalidInputError(f"model built for another bit depth than {rgb.dtype}")
    shape = rgb.shape[:2]
    flags = np.empty(shape + (4,), dtype=np.uint8)
    veto = np.empty(shape, dtype=np.bool_)
    min_sum = int(math.ceil(3.0 * min_intensity * (model.lut.shape[0] - 1)))
    lookup_kernel(rgb, model.lut, model.table, min_sum, flags, veto)
    return flags, veto


__all__ = ["GroundColourParameters", "GroundColourModel", "build_ground_colour_model", "colour_flags",
           "shadow_shifts", "select_shifts", "GROUND_BIT", "SHADOW_BIT", "SUNLIT_BIT"]
