"""The free range in each direction: the nearest obstacle per sector of bearing, like a planar laser scan.

The obstacle list says what is in front and how far each object's near face is; a robot
planning a path, or a person deciding where to step, also asks "how far can I go *this* way?".
The scan answers it for every direction the camera sees. The horizontal field of view is cut
into sectors of ``sector_deg`` degrees of bearing (the angle in the camera's x-z plane,
``atan2(x, z)``: 0 straight ahead along the optical axis, positive to the right), aligned to
whole multiples of ``sector_deg`` so that the sectors stay put from frame to frame. A pixel's
bearing depends only on its column, ``atan2(u - cx, f)``.

In each sector, each reported obstacle with at least ``min_pixels`` pixels of known depth there
gets a range: a low ``percentile`` of its pixels' horizontal ranges ``sqrt(x^2 + z^2)`` (the
10th in the pipeline, which keeps one noisy match from setting it).
The sector's range is the smallest of these, with the obstacle it belongs to; a sector without
such an obstacle has none (free at least up to the largest distance obstacles are reported to,
or not seen: the scan cannot tell these apart).

Ranges are horizontal (height ``y`` left out) and measured from the left camera's optical
centre. Object outlines are matched a few pixels wide (window matching), so a sector just beside
an object can take its range (``docs/pipeline.md``, "Free range per direction").
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from stereo_obstacles._direction_scan_kernel import sector_ranges_kernel
from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import is_finite_real, is_whole_number


MIN_SECTOR_DEG = 0.01
"""Narrowest sector, degrees of bearing (a pixel of a 1242-px-wide KITTI image spans 0.08)."""

MAX_BUCKETS = 4_000_000
"""Sectors times obstacle numbers above which the ids are renumbered 1..n first (the kernel
counts pixels per sector and number)."""


@dataclass(frozen=True)
class DirectionScan:
    """The nearest obstacle's horizontal range in each sector of bearing.

    Sector ``k`` covers bearings ``[first_bearing_deg + k * sector_deg, first_bearing_deg +
    (k + 1) * sector_deg)`` (degrees, positive to the right of the optical axis); the image sees
    the bearings ``field_of_view_deg`` (its first and last pixel columns), so the first and the
    last sector are seen in part. ``ranges_m[k]`` is the range in metres to the nearest obstacle
    in sector ``k`` and ``obstacle_ids[k]`` its id (both ``None``: no obstacle reported there;
    a range without an id: its obstacle has no number, e.g. an untracked one).

    Raises
    ------
    InvalidInputError
        A sector width outside ``[MIN_SECTOR_DEG, 180]``, bearings that are not finite, lists
        of other lengths, a range that is not a finite number > 0, an id that is not an integer
        >= 1, or an id without a range.
    """

    sector_deg: float
    first_bearing_deg: float
    field_of_view_deg: tuple[float, float]
    ranges_m: tuple[float | None, ...]
    obstacle_ids: tuple[int | None, ...]

    def __post_init__(self) -> None:
        if not (is_finite_real(self.sector_deg) and MIN_SECTOR_DEG <= self.sector_deg <= 180):
            raise InvalidInputError(f"sector_deg must be a number of degrees in [{MIN_SECTOR_DEG}, 180], got "
                                    f"{self.sector_deg!r}")
        view = tuple(self.field_of_view_deg) if isinstance(self.field_of_view_deg, (tuple, list)) else ()
        if not (isinstance(self.ranges_m, tuple) and isinstance(self.obstacle_ids, tuple)
                and len(self.ranges_m) == len(self.obstacle_ids) >= 1):
            raise InvalidInputError("ranges_m and obstacle_ids must be tuples with one value per sector, of at "
                                    "least one sector")
        end = self.first_bearing_deg + len(self.ranges_m) * self.sector_deg if is_finite_real(self.first_bearing_deg) else 0
        if not (is_finite_real(self.first_bearing_deg) and len(view) == 2 and all(is_finite_real(b) for b in view)
                and self.first_bearing_deg <= view[0] <= view[1] <= end):
            raise InvalidInputError(f"first_bearing_deg ({self.first_bearing_deg!r}) and field_of_view_deg "
                                    f"({self.field_of_view_deg!r}) must be finite bearings, the view from left to "
                                    f"right and within the sectors")
        for rng, obstacle in zip(self.ranges_m, self.obstacle_ids):
            if rng is not None and not (is_finite_real(rng) and rng > 0):
                raise InvalidInputError(f"ranges_m must be None or numbers of metres > 0, got {rng!r}")
            if obstacle is not None and not (is_whole_number(obstacle) and obstacle >= 1 and rng is not None):
                raise InvalidInputError(f"obstacle_ids must be None or integers >= 1 with a range, got {obstacle!r}")

    def renumbered(self, new_ids: np.ndarray) -> DirectionScan:
        """The same scan with each obstacle id ``i`` replaced by ``new_ids[i]`` (``int``, 0 or
        out of range: no id; the range stays)."""
        def new(i: int | None) -> int | None:
            value = int(new_ids[i]) if i is not None and 0 <= i < len(new_ids) else 0
            return value if value > 0 else None
        return replace(self, obstacle_ids=tuple(new(i) for i in self.obstacle_ids))

    def bearings_deg(self) -> np.ndarray:
        """``float64 (n,)``: the bearing at the middle of each sector, degrees."""
        return self.first_bearing_deg + (np.arange(len(self.ranges_m)) + 0.5) * self.sector_deg


def column_bearings_deg(width_px: int, calibration: StereoCalibration) -> np.ndarray:
    """``float64 (width_px,)``: the bearing of each image column, ``atan2(u - cx, f)`` in degrees."""
    return np.degrees(np.arctan2(np.arange(width_px) - calibration.cx_px, calibration.focal_px))


def sector_of_columns(width_px: int, calibration: StereoCalibration, sector_deg: float) -> tuple[np.ndarray, float]:
    """The sector of each image column (``int64 (width_px,)``, from 0) and the bearing where
    sector 0 begins (degrees, a whole multiple of ``sector_deg``)."""
    if not (is_finite_real(sector_deg) and MIN_SECTOR_DEG <= sector_deg <= 180):
        raise InvalidInputError(f"sector_deg must be a number of degrees in [{MIN_SECTOR_DEG}, 180], "
                                f"got {sector_deg!r}")
    bearings = column_bearings_deg(width_px, calibration)
    first = math.floor(bearings[0] / sector_deg) * sector_deg
    return np.floor((bearings - first) / sector_deg).astype(np.int64), first


def direction_scan(id_map: np.ndarray, disparity: np.ndarray, calibration: StereoCalibration, *,
                   sector_deg: float, min_pixels: int, percentile: float) -> DirectionScan:
    """The scan of the module docstring.

    Parameters
    ----------
    id_map
        ``int (H, W)``: the obstacle each pixel belongs to, 0 for none (negative: none either).
    disparity
        ``float (H, W)`` disparity in pixels, NaN where unmatched (pixels without a finite
        depth, ``disparity + doffs`` not finite or ``<= 0``, are left out).
    calibration
        The rectified calibration the obstacles were measured with.
    sector_deg
        Width of a sector, degrees of bearing, in ``[MIN_SECTOR_DEG, 180]``.
    min_pixels
        Pixels of known depth an obstacle needs in a sector to count there (an integer >= 1).
    percentile
        Percentile (0-100) of an obstacle's pixel ranges in a sector taken as its range there.

    Returns
    -------
    DirectionScan

    Raises
    ------
    InvalidInputError
        Maps of other shapes or without a column, no calibration, or an argument out of range.

    Examples
    --------
    A 1 m wide box 4 m straight ahead of a camera with a 500 px focal length:

    >>> camera = StereoCalibration(focal_px=500.0, cx_px=100.0, cy_px=50.0, baseline_m=0.1)
    >>> ids = np.zeros((100, 200), np.int32); ids[40:60, 38:163] = 1
    >>> disparity = np.full((100, 200), 12.5, np.float32)            # f B / 4 m
    >>> scan = direction_scan(ids, disparity, camera, sector_deg=5.0, min_pixels=10, percentile=0.0)
    >>> scan.first_bearing_deg, [round(b, 1) for b in scan.field_of_view_deg], scan.ranges_m
    (-15.0, [-11.3, 11.2], (None, 4.015, 4.0, 4.0, 4.015, None))
    """
    id_map = np.asarray(id_map)
    d = np.asarray(disparity)
    if not isinstance(calibration, StereoCalibration):
        raise InvalidInputError(f"calibration must be a StereoCalibration, got {type(calibration).__name__}")
    if id_map.ndim != 2 or id_map.shape != d.shape or id_map.shape[1] == 0:
        raise InvalidInputError(f"id_map {id_map.shape} and disparity {d.shape} must be the same 2-D shape, with "
                                f"columns")
    if not (is_finite_real(percentile) and 0 <= percentile <= 100):
        raise InvalidInputError(f"percentile must lie in [0, 100], got {percentile!r}")
    if not (is_whole_number(min_pixels) and min_pixels >= 1):
        raise InvalidInputError(f"min_pixels must be an integer >= 1, got {min_pixels!r}")
    sector_of, first = sector_of_columns(id_map.shape[1], calibration, sector_deg)
    n_sectors = int(sector_of[-1]) + 1
    compact, ids = _compact_ids(id_map, n_sectors)
    nearest, nearest_compact = sector_ranges_kernel(compact, len(ids), np.ascontiguousarray(d, dtype=np.float32),
                                                    sector_of,
                                                    n_sectors, float(calibration.cx_px), float(calibration.focal_px),
                                                    float(calibration.focal_baseline_px_m),
                                                    float(calibration.doffs_px), int(min_pixels), float(percentile))
    view = column_bearings_deg(id_map.shape[1], calibration)[[0, -1]]
    return DirectionScan(sector_deg=float(sector_deg), first_bearing_deg=float(first),
                         field_of_view_deg=(float(view[0]), float(view[1])),
                         ranges_m=tuple(None if math.isnan(r) else max(round(float(r), 3), 0.001) for r in nearest),
                         obstacle_ids=tuple(int(ids[i]) if i > 0 else None for i in nearest_compact))


def _compact_ids(id_map: np.ndarray, n_sectors: int) -> tuple[np.ndarray, np.ndarray]:
    """``int32 (H, W)`` numbers the kernel can take (0: none) and ``int64`` the id of each number:
    the ids themselves when they are few enough (the pipeline's 1..N), else renumbered."""
    top = int(id_map.max(initial=0))
    if top * n_sectors <= MAX_BUCKETS:
        return np.ascontiguousarray(id_map, dtype=np.int32), np.arange(top + 1, dtype=np.int64)
    ids, numbers = np.unique(np.where(id_map > 0, id_map, 0), return_inverse=True)
    numbers = numbers.reshape(id_map.shape).astype(np.int32)
    if ids[0] != 0:                                            # every pixel holds an obstacle
        ids, numbers = np.concatenate([[0], ids]), numbers + 1
    return numbers, ids.astype(np.int64)

__all__ = ["MAX_BUCKETS", "MIN_SECTOR_DEG", "DirectionScan", "column_bearings_deg", "direction_scan",
           "sector_of_columns"]
