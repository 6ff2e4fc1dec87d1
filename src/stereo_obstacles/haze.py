"""Aerial perspective: far ground takes on the colour of the horizon.

The air between the camera and a distant surface scatters light of the horizon's colour (the
airlight ``A``) into the view: ground of colour ``c0`` at distance ``z`` is seen as

    ``c = c0 (1 - h) + A h``,  ``h = 1 - exp(-z / z_haze)``

(Koschmieder's law). Towards the horizon the ground's colour leaves the reference area's
colours, and phase 1 calls a band of far ground obstacle (on the synthetic world 42 % of the
ground pixels it called obstacle lay where the ground plane's disparity is under 2 px:
docs/segmentation.md). With the stereo ground plane ``d = a x + b y + c`` the ground at row
``y`` is at ``f B / d``, so its haze is ``h(y) = 1 - exp(-k / d(y))`` with one unknown,
``k = f B / z_haze``, and no calibration is needed (:func:`estimate_haze`):

1. ``A`` is the median colour of the rows at the plane's horizon (``d = 0``), and must be
   brighter than the reference area (airlight is bright; on KITTI those rows are dark buildings
   and trees, and nothing is done);
2. every row whose plane disparity is in ``estimate_disparity_px`` gives ``h`` from its median
   colour, projected on the line from the reference colour to ``A``, and so a ``k``; their
   median is taken. The rows of the near end of that range must show almost no haze
   (``max_near_haze``): otherwise the colour drifts with distance for another reason (a paved
   ground whose mortar lines blend with distance) and nothing is done.

Then (:func:`hazy_ground`) only the far ground, at least ``min_distance_factor`` times as far
as the reference area, is cleared of the haze, ``c0 = (c - A h) / (1 - h)`` (``h`` capped at
``max_haze``), and its obstacle pixels whose ``window_px`` square is mostly (``ground_fraction``)
of the ground's colours (lit, shadowed or sunlit) become ground, unless the stereo check saw
them off the ground, and whose column of obstacle pixels does not run on, unbroken, down to
ground half as far as the band's edge (an obstacle standing on nearer ground and reaching up
into the far rows keeps its pixels).
Nearer rows are never touched: on paved ground a wider band cost up to 2.5 points of recall.
Flipped pixels become GROUND (a far cast shadow is not told apart). The colour test uses the
log-RGB ground colour model whichever colour model phase 1 used (only the default, log-RGB,
was evaluated).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import cv2
import numpy as np

from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import check_integers, check_numbers
from stereo_obstacles.ground_colour import GroundColourParameters, build_ground_colour_model, colour_flags
from stereo_obstacles.ground_plane import GroundPlane

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class HazeParameters:
    """Settings of the far-ground haze correction (defaults measured in docs/segmentation.md).

    Attributes
    ----------
    enabled
        False leaves the labels as they are.
    horizon_rows
        ``A`` is the median colour of this many rows ending at the plane's horizon row.
    min_airlight_ratio
        ``A``'s mean channel must be at least this times the reference area's.
    estimate_disparity_px
        ``(low, high)``: rows whose plane disparity (at the middle column) is in this range,
        pixels, estimate ``k``.
    min_estimate_rows
        Fewer usable rows (``0 < h < 0.95``): no correction.
    near_disparity_px, max_near_haze
        The median haze of the estimate rows with a plane disparity of at least
        ``near_disparity_px`` must not exceed ``max_near_haze``.
    min_distance_factor
        Only ground at least this many times as far as the reference area's middle row (plane
        disparity at most ``1 / min_distance_factor`` of that row's) is corrected.
    min_haze, max_haze
        Rows with less haze are left alone; more is capped (clearing multiplies the noise by
        ``1 / (1 - h)``).
    window_px, ground_fraction
        A far obstacle pixel becomes ground when more than ``ground_fraction`` of its
        ``window_px`` square, cleared of the haze, has a ground colour.
    """

    enabled: bool = True
    horizon_rows: int = 3
    min_airlight_ratio: float = 1.2
    estimate_disparity_px: tuple[float, float] = (0.5, 8.0)
    min_estimate_rows: int = 5
    near_disparity_px: float = 6.0
    max_near_haze: float = 0.08
    min_distance_factor: float = 10.0
    min_haze: float = 0.02
    max_haze: float = 0.6
    window_px: int = 7
    ground_fraction: float = 0.5

    def __post_init__(self) -> None:
        if not isinstance(self.enabled, bool):
            raise InvalidInputError(f"enabled must be a bool, got {self.enabled!r}")
        check_integers(self, (("horizon_rows", 1, 1000), ("min_estimate_rows", 1, 1000)))
        check_integers(self, (("window_px", 1, 255),), odd=True)
        pair = self.estimate_disparity_px
        if (not isinstance(pair, tuple) or len(pair) != 2
                or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in pair)
                or not 0 <= pair[0] < pair[1]):
            raise InvalidInputError(f"estimate_disparity_px must be (low, high) with 0 <= low < high, got {pair!r}")
        check_numbers(self, (("min_airlight_ratio", 0.0, 100.0), ("near_disparity_px", 0.0, 1000.0),
                             ("max_near_haze", 0.0, 1.0), ("min_distance_factor", 1.0, 1000.0),
                             ("min_haze", 0.0, 1.0), ("max_haze", 0.0, 0.95), ("ground_fraction", 0.0, 1.0)))
        if not self.estimate_disparity_px[0] <= self.near_disparity_px <= self.estimate_disparity_px[1]:
            raise InvalidInputError(f"near_disparity_px must be within estimate_disparity_px "
                                    f"{self.estimate_disparity_px}, got {self.near_disparity_px}")
        if self.min_haze > self.max_haze:
            raise InvalidInputError(f"min_haze must not exceed max_haze, got {self.min_haze} > {self.max_haze}")


@dataclass(frozen=True, eq=False)
class HazeEstimate:
    """The haze of one image's ground.

    Attributes
    ----------
    airlight
        ``A``, RGB in the image's units.
    k_px
        ``f B / z_haze``, pixels of disparity.
    haze
        ``float64 (H,)``: ``h`` of the ground at each row, capped at ``max_haze``; rows at or
        above the plane's horizon get the cap.
    row_disparity
        ``float64 (H,)``: the plane's disparity at the middle column of each row, pixels.
    """

    airlight: tuple[float, float, float]
    k_px: float
    haze: np.ndarray = field(repr=False)
    row_disparity: np.ndarray = field(repr=False)


def estimate_haze(rgb: np.ndarray, plane: GroundPlane, box: tuple[int, int, int, int], *,
                  params: HazeParameters = HazeParameters()) -> HazeEstimate | None:
    """The airlight and the haze of each row, or None when the image gives no usable estimate.

    Parameters
    ----------
    rgb
        ``(H, W, 3)`` RGB image (``uint8`` or ``uint16``).
    plane
        The ground plane in disparity space (rows below its horizon have ``d > 0``).
    box
        Reference area ``(x0, y0, x1, y1)``, pixels, end exclusive: the near ground's colour.
    params
        See :class:`HazeParameters`.
    """
    height, width = rgb.shape[:2]
    if not (params.enabled and plane.b > 0):
        return None
    middle = width / 2.0
    row_disparity = plane.a * middle + plane.b * np.arange(height) + plane.c
    horizon_row = -(plane.c + plane.a * middle) / plane.b
    if not (params.horizon_rows - 1 <= horizon_row < height - 2.5):       # also an infinite one (b ~ 0)
        return None
    horizon = int(round(horizon_row))
    x0, y0, x1, y1 = box
    ground = np.median(rgb[y0:y1, x0:x1].reshape(-1, 3), axis=0).astype(np.float64)
    airlight = np.median(rgb[horizon - params.horizon_rows + 1:horizon + 1].reshape(-1, 3), axis=0).astype(np.float64)
    direction = airlight - ground
    length_sq = float(direction @ direction)
    grey_level = float(np.iinfo(rgb.dtype).max) / 255.0                  # one 8-bit grey level in the image's units
    if length_sq < (10.0 * grey_level) ** 2 or airlight.mean() < params.min_airlight_ratio * ground.mean():
        return None                                                        # no distinct airlight colour
    low, high = params.estimate_disparity_px
    rows = horizon + 1 + np.flatnonzero(row_disparity[horizon + 1:] >= low)
    rows = rows[np.cumsum(row_disparity[rows] > high) == 0]           # down to the first row beyond high
    if rows.size == 0:
        return None
    h = (np.median(rgb[rows], axis=1) - ground) @ direction / length_sq
    near = h[row_disparity[rows] >= params.near_disparity_px]
    usable = (h > 0.0) & (h < 0.95)
    if (np.count_nonzero(usable) < params.min_estimate_rows or near.size == 0
            or float(np.median(near)) > params.max_near_haze):
        return None
    k = float(np.median(-row_disparity[rows][usable] * np.log1p(-h[usable])))
    with np.errstate(divide="ignore", over="ignore"):
        haze = np.where(row_disparity > 0, -np.expm1(-k / np.maximum(row_disparity, 1e-12)), 1.0)
    return HazeEstimate(airlight=tuple(float(v) for v in airlight), k_px=k,
                        haze=np.minimum(haze, params.max_haze), row_disparity=row_disparity)


def _standing_on_nearer_ground(obstacle: np.ndarray, rows: np.ndarray, near_row: int) -> np.ndarray:
    """``bool (len(rows), W)``: pixels of the contiguous band ``rows`` whose column of obstacle
    pixels runs on, unbroken, down to ``near_row`` (where the ground is at most half as far as
    at the band's edge): part of an obstacle standing on nearer ground (a pole, a box taller than
    the camera), not of the far ground or of the haze's fringe just below the band."""
    height, width = obstacle.shape
    below = obstacle[near_row] if near_row < height else np.zeros(width, dtype=np.bool_)
    for row in range(min(near_row, height) - 1, int(rows[-1]), -1):
        below = obstacle[row] & below
    runs = np.empty((rows.size, width), dtype=np.bool_)
    for i in range(rows.size - 1, -1, -1):
        below = obstacle[rows[i]] & below
        runs[i] = below
    return runs


def hazy_ground(rgb: np.ndarray, obstacle: np.ndarray, estimate: HazeEstimate, box: tuple[int, int, int, int], *,
                min_intensity: float, ground_colour: GroundColourParameters = GroundColourParameters(),
                shadow_ratio: tuple[float, float] | None = (0.4, 0.8),
                params: HazeParameters = HazeParameters()) -> np.ndarray:
    """``bool (H, W)``: obstacle pixels of the far ground that are ground seen through the haze.

    Parameters
    ----------
    rgb
        ``(H, W, 3)`` C-contiguous ``uint8``/``uint16`` RGB image.
    obstacle
        ``bool (H, W)``: the pixels that may be ground (phase 1's obstacles that the stereo
        check did not see off the ground).
    estimate
        From :func:`estimate_haze`.
    box
        Reference area ``(x0, y0, x1, y1)``, pixels: the ground colours, and the distance the
        far ground is measured against.
    min_intensity
        Pixels darker than this (fraction of full scale) have no measurable colour.
    ground_colour, shadow_ratio
        The ground colour model (:func:`stereo_obstacles.ground_colour.build_ground_colour_model`).
    params
        See :class:`HazeParameters`.
    """
    result = np.zeros(obstacle.shape, dtype=np.bool_)
    reference_row = (box[1] + box[3]) / 2.0
    d = estimate.row_disparity
    reference_disparity = float(np.interp(reference_row, np.arange(d.size), d))
    far = (d > 0) & (estimate.haze > params.min_haze) & (d < reference_disparity / params.min_distance_factor)
    rows = np.flatnonzero(far)
    if rows.size == 0 or not obstacle[rows].any():
        return result
    r = params.window_px // 2
    top, bottom = max(0, int(rows[0]) - r), min(rgb.shape[0], int(rows[-1]) + 1 + r)   # the windows' rows
    h = estimate.haze[top:bottom, None, None]
    full_scale = float(np.iinfo(rgb.dtype).max)
    cleared = np.clip(np.rint((rgb[top:bottom] - np.array(estimate.airlight) * h) / (1.0 - h)), 0, full_scale)
    model = build_ground_colour_model(rgb, box, params=ground_colour, shadow_ratio=shadow_ratio)
    flags, _ = colour_flags(np.ascontiguousarray(cleared.astype(rgb.dtype)), model, min_intensity)
    ground_like = (flags[..., 0] | flags[..., 1] | flags[..., 2]).astype(np.float32)
    share = cv2.blur(ground_like, (params.window_px, params.window_px))
    edge = reference_disparity / params.min_distance_factor
    near_row = int(np.searchsorted(d, 2.0 * edge)) if d[-1] >= 2.0 * edge else d.size   # d grows down the image
    standing = _standing_on_nearer_ground(obstacle, rows, near_row)
    result[rows] = obstacle[rows] & (share[rows - top] > params.ground_fraction) & ~standing
    logger.debug("haze: airlight %s, k %.3f px, %d far obstacle pixels made ground", estimate.airlight,
                 estimate.k_px, np.count_nonzero(result))
    return result


__all__ = ["HazeParameters", "HazeEstimate", "estimate_haze", "hazy_ground"]
