"""Far ground takes its colour from its own rows, not from the reference area.

The reference area shows the near ground. Far away the ground's colour drifts. Each pixel
covers many texels, so the texture is averaged, and the air blends every surface with the
horizon's colour (aerial perspective). Near the horizon the colour model of phase 1 then
calls the ground an obstacle: a band of false alarms under the horizon. On the synthetic
world it held 1.7-2.3 % of the ground pixels (docs/segmentation.md, session 8).

With the stereo check's ground plane ``d = a x + b y + c``, the far rows are known. They are
the rows above the reference area whose plane disparity (at the middle column) is positive but
at most ``1 / min_distance_factor`` of the reference area's, so their ground is at least that
many times as far. Such a row is mostly ground, so the median colour of its pixels is the ground's colour
at that distance. :func:`far_ground` walks these rows from the nearest upwards:

1. the row's colour is the median, per channel, of ``log(1 + c)`` over the row's pixels that
   the stereo check does not see off the ground (``c`` the colour after a ``blur_px`` box blur);
2. the walk starts from the row just under the band, whose colour is taken the same way
   (nothing is done when fewer than ``min_row_fraction`` of that row's pixels qualify). It
   stops at a row where fewer than ``min_row_fraction`` of the pixels qualify, or whose colour
   differs from the row below by more than ``max_row_step`` in a channel (the ground's colour
   changes gradually with distance; a jump means that something else fills the row: the sky
   above a dark building that hides the far ground);
3. obstacle pixels within ``colour_tolerance`` of the row's colour in every channel become
   ground, unless their column of obstacle pixels runs on, unbroken, down to ground half as far
   as the band's edge and they have the colour of that column just under the band (an
   obstacle standing on nearer ground and reaching up into the far rows keeps its pixels; the
   far ground seen above the top of a near obstacle does not).

Steps 1 and 2 need only the image and the stereo check (:func:`far_ground_rows`, which
phase 1 runs beside its colour labels); step 3 needs the labels (:func:`far_ground_pixels`).
:func:`far_ground` does both.

Nearer rows are never touched. The sky can be called ground, which changes nothing a user
relies on (the sky is no obstacle either), but shows in the labels:

* where the far ground meets the sky, the sky near the horizon has nearly the far ground's
  colour (the haze makes both the horizon's colour), so about one row of sky may be called
  ground there (0.76 % of the sky pixels of seeds 0..19);
* when a wall hides the far ground, the far rows show the sky above the wall. If the wall's
  top is of about the sky's colour, the walk goes on into the sky. Seed 523 of the synthetic
  world has 25 600 sky pixels called ground this way. Requiring phase 1 to call the row under
  the band ground would prevent it, but that row is mostly false alarms itself on many
  scenes: BER rose by 0.24-0.52 point on the four choosing sets.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import cv2
import numpy as np

from stereo_obstacles._far_ground_kernel import far_rows_kernel
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import check_integers, check_numbers
from stereo_obstacles.ground_plane import GroundPlane

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class FarGroundParameters:
    """Settings of the far-ground rows (defaults measured in docs/segmentation.md).

    Attributes
    ----------
    enabled
        False leaves the labels as they are.
    min_distance_factor
        Only rows above the reference area whose ground is at least this many times as far as
        the reference area's middle are far: plane disparity at the image's middle column
        positive and at most ``1 / min_distance_factor`` of the disparity at the area's middle.
    blur_px
        Side of the box blur applied to the colours first, pixels (odd; 1: none).
    colour_tolerance
        An obstacle pixel becomes ground when ``log(1 + c)`` is within this of the row's colour
        in every channel (0.08: about 8 %).
    max_row_step
        The walk up the far rows stops where the row colour changes by more than this in a
        channel from the row below (log units).
    min_row_fraction
        The walk stops at a row with fewer than this fraction of its pixels not off the ground.
    """

    enabled: bool = True
    min_distance_factor: float = 10.0
    blur_px: int = 5
    colour_tolerance: float = 0.08
    max_row_step: float = 0.1
    min_row_fraction: float = 0.25

    def __post_init__(self) -> None:
        if not isinstance(self.enabled, bool):
            raise InvalidInputError(f"enabled must be a bool, got {self.enabled!r}")
        check_integers(self, (("blur_px", 1, 255),), odd=True)
        check_numbers(self, (("min_distance_factor", 1.0, 1000.0), ("colour_tolerance", 0.0, 10.0),
                             ("max_row_step", 0.0, 10.0), ("min_row_fraction", 0.0, 1.0)))


def far_rows(plane: GroundPlane, shape: tuple[int, int], box: tuple[int, int, int, int],
             min_distance_factor: float) -> tuple[np.ndarray, int]:
    """The far rows of an ``(H, W)`` image, and the first row of the near ground.

    Returns
    -------
    (numpy.ndarray, int)
        ``int`` indices, increasing, of the rows above the reference area ``box``
        ``(x0, y0, x1, y1)`` whose ground is at least ``min_distance_factor`` times as far as the
        box's middle (plane disparity at the middle column positive and at most the box
        middle's divided by the factor; none when the plane does not rise towards the bottom),
        and the first row whose ground is at most half as far as that edge of the band
        (``H`` when there is none).
    """
    height, width = shape
    row_disparity = plane.a * (width / 2.0) + plane.b * np.arange(height) + plane.c
    edge = (plane.a * (box[0] + box[2]) / 2.0 + plane.b * (box[1] + box[3]) / 2.0 + plane.c) / min_distance_factor
    if not plane.b > 0:
        return np.zeros(0, dtype=np.int64), height
    near = np.flatnonzero(row_disparity >= 2.0 * edge)
    far = (row_disparity > 0) & (row_disparity <= edge) & (np.arange(height) < box[1])
    return np.flatnonzero(far), int(near[0]) if near.size else height


def _standing_on_nearer_ground(obstacle: np.ndarray, rows: np.ndarray, near_row: int) -> np.ndarray:
    """``bool (len(rows), W)``: pixels of the contiguous band ``rows`` whose column of obstacle
    pixels runs on, unbroken, down to ``near_row`` (where the ground is at most half as far as
    at the band's edge): part of an obstacle standing on nearer ground (a pole, a box taller than
    the camera), not of the far ground."""
    height, width = obstacle.shape
    below = obstacle[near_row] if near_row < height else np.zeros(width, dtype=np.bool_)
    for row in range(min(near_row, height) - 1, int(rows[-1]), -1):
        below = obstacle[row] & below
    runs = np.empty((rows.size, width), dtype=np.bool_)
    for i in range(rows.size - 1, -1, -1):
        below = obstacle[rows[i]] & below
        runs[i] = below
    return runs


def _check_image_and_box(rgb: np.ndarray, off_ground: np.ndarray, box: tuple[int, int, int, int]) -> None:
    """Raise :class:`InvalidInputError` unless the image, the off-ground mask and the box fit
    :func:`far_ground_rows`."""
    if not (isinstance(rgb, np.ndarray) and rgb.ndim == 3 and rgb.shape[2] == 3
            and rgb.dtype in (np.uint8, np.uint16)):
        raise InvalidInputError(f"rgb must be a uint8 or uint16 (H, W, 3) array, got "
                                f"{getattr(rgb, 'dtype', type(rgb))} {getattr(rgb, 'shape', '')}")
    _check_mask("off_ground", off_ground, rgb.shape[:2])
    if not (isinstance(box, tuple) and len(box) == 4 and all(isinstance(v, (int, np.integer)) for v in box)):
        raise InvalidInputError(f"box must be a tuple of four integers (x0, y0, x1, y1), got {box!r}")
    x0, y0, x1, y1 = box
    if not (0 <= x0 < x1 <= rgb.shape[1] and 0 <= y0 < y1 <= rgb.shape[0]):
        raise InvalidInputError(f"box {box} is not a non-empty rectangle inside the "
                                f"{rgb.shape[1]}x{rgb.shape[0]} image")


def _check_mask(name: str, mask: np.ndarray, shape: tuple[int, ...]) -> None:
    """Raise :class:`InvalidInputError` unless ``mask`` is a ``bool`` array of ``shape``."""
    if not (isinstance(mask, np.ndarray) and mask.dtype == np.bool_ and mask.shape == shape):
        raise InvalidInputError(f"{name} must be a bool array of the image's shape {shape}, got "
                                f"{getattr(mask, 'dtype', type(mask))} {getattr(mask, 'shape', '')}")


@dataclass(frozen=True, eq=False)
class FarGroundRows:
    """What :func:`far_ground_rows` finds in the far rows before the labels are known.

    Attributes
    ----------
    shape
        ``(H, W)`` of the image.
    rows
        ``int (n,)`` indices, increasing, of the far rows (:func:`far_rows`).
    near_row
        The first row of ground at most half as far as the band's edge (``H`` when none).
    ground_coloured
        ``bool (n, W)``: pixels of the far rows within the tolerance of their row's ground colour
        and not off the ground.
    colour_under_band
        ``bool (n, W)``: pixels of the far rows with the colour of their column just under the band.
    """

    shape: tuple[int, int]
    rows: np.ndarray
    near_row: int
    ground_coloured: np.ndarray
    colour_under_band: np.ndarray


def far_ground_rows(rgb: np.ndarray, off_ground: np.ndarray, plane: GroundPlane, box: tuple[int, int, int, int], *,
                    params: FarGroundParameters = FarGroundParameters()) -> FarGroundRows | None:
    """The far rows' ground-coloured pixels: the part of :func:`far_ground` that does not need
    phase 1's labels (phase 1 computes it beside the colour labels). Arguments as for
    :func:`far_ground`; None when ``params.enabled`` is False or there is no far row.

    Raises
    ------
    InvalidInputError
        As :func:`far_ground`.
    """
    _check_image_and_box(rgb, off_ground, box)
    if not params.enabled:
        return None
    shape = off_ground.shape
    rows, near_row = far_rows(plane, shape, box, params.min_distance_factor)
    if rows.size == 0:
        return None
    r = params.blur_px // 2
    below = int(rows[-1]) + 1                               # the first row under the band
    top, bottom = max(0, int(rows[0]) - r), min(shape[0], below + 1 + r)
    colours = rgb[top:bottom].astype(np.float32)
    if params.blur_px > 1:
        colours = cv2.blur(colours, (params.blur_px, params.blur_px), borderType=cv2.BORDER_REFLECT)
    colours = np.log1p(colours)
    walked = np.append(rows, below)                         # the far rows and the row under them
    band = np.ascontiguousarray(colours[walked - top])
    min_count = max(1, int(np.ceil(params.min_row_fraction * shape[1])))
    like = np.zeros((rows.size, shape[1]), dtype=np.bool_)
    far_rows_kernel(band, np.ascontiguousarray(off_ground[walked]), min_count, np.float32(params.colour_tolerance),
                    np.float32(params.max_row_step), like)
    close = np.abs(band[:-1] - band[-1]) <= params.colour_tolerance   # per channel (4x faster than np.all(axis=2))
    return FarGroundRows(shape=shape, rows=rows, near_row=near_row, ground_coloured=like & ~off_ground[rows],
                         colour_under_band=close[..., 0] & close[..., 1] & close[..., 2])


def far_ground_pixels(found: FarGroundRows | None, obstacle: np.ndarray) -> np.ndarray:
    """``bool (H, W)``: the obstacle pixels that ``found`` (:func:`far_ground_rows`) makes ground.

    An obstacle standing on nearer ground that reaches up into the band with the colour it has
    under the band keeps its pixels (a near untextured box of the far ground's colour).

    Raises
    ------
    InvalidInputError
        ``found`` is neither :class:`FarGroundRows` nor None, or ``obstacle`` is not ``bool``
        of the image's shape (``(H, W)``).
    """
    if found is not None and not isinstance(found, FarGroundRows):
        raise InvalidInputError(f"found must be FarGroundRows or None, got {type(found).__name__}")
    shape = found.shape if found is not None else np.shape(obstacle)
    if len(shape) != 2:
        raise InvalidInputError(f"obstacle must be a bool (H, W) array, got shape {shape}")
    _check_mask("obstacle", obstacle, shape)
    result = np.zeros(shape, dtype=np.bool_)
    if found is None:
        return result
    rows = found.rows
    kept = _standing_on_nearer_ground(obstacle, rows, found.near_row) & found.colour_under_band
    result[rows] = obstacle[rows] & found.ground_coloured & ~kept
    logger.debug("far ground: %d far rows, %d obstacle pixels made ground", rows.size, np.count_nonzero(result))
    return result


def far_ground(rgb: np.ndarray, obstacle: np.ndarray, off_ground: np.ndarray, plane: GroundPlane,
               box: tuple[int, int, int, int], *,
               params: FarGroundParameters = FarGroundParameters()) -> np.ndarray:
    """``bool (H, W)``: obstacle pixels of the far rows that have their row's ground colour.

    Parameters
    ----------
    rgb
        ``(H, W, 3)`` RGB image (``uint8`` or ``uint16``).
    obstacle
        ``bool (H, W)``: the pixels phase 1 calls obstacle.
    off_ground
        ``bool (H, W)``: the pixels the stereo check sees off the ground plane (never turned
        into ground, and left out of the row colours).
    plane
        The ground plane in disparity space.
    box
        Reference area ``(x0, y0, x1, y1)``, pixels, end exclusive: the far rows are measured
        against its distance.
    params
        See :class:`FarGroundParameters`.

    Raises
    ------
    InvalidInputError
        ``rgb`` is not ``uint8``/``uint16 (H, W, 3)``, a mask is not ``bool (H, W)``, or
        ``box`` is not four integers of a non-empty rectangle inside the image.

    Examples
    --------
    >>> import numpy as np
    >>> from stereo_obstacles.ground_plane import GroundPlane
    >>> rows = np.linspace(0.0, 1.0, 100)[:, None, None]             # towards the horizon (row 0)
    >>> rgb = np.broadcast_to((90 + 120 * (1 - rows) ** 8) * [1.0, 1.2, 0.7], (100, 80, 3)).astype(np.uint8)
    >>> obstacle = np.zeros((100, 80), bool)
    >>> obstacle[1:10] = obstacle[60:70, 10:20] = True               # the far band, and a near box
    >>> plane = GroundPlane(a=0.0, b=0.2, c=0.0)                     # d = 0.2 y: horizon at row 0
    >>> flipped = far_ground(rgb, obstacle, np.zeros_like(obstacle), plane, (0, 85, 80, 100))
    >>> bool(flipped[1:10].all()), bool(flipped[10:].any())          # far: d <= 18.5 / 10, rows 1..9
    (True, False)
    """
    found = far_ground_rows(rgb, off_ground, plane, box, params=params)    # checks the image, mask and box
    _check_mask("obstacle", obstacle, off_ground.shape)
    return far_ground_pixels(found, obstacle)


__all__ = ["FarGroundParameters", "FarGroundRows", "far_rows", "far_ground_rows", "far_ground_pixels",
           "far_ground"]
