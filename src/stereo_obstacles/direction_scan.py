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
same percentile as the obstacle's own distance, which keeps one noisy match from setting it).
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


@dataclass(frozen=True)
class DirectionScan:
    """The nearest obstacle's horizontal range in each sector of bearing.

    Sector ``k`` covers bearings ``[first_bearing_deg + k * sector_deg, first_bearing_deg +
    (k + 1) * sector_deg)`` (degrees, positive to the right of the optical axis); ``ranges_m[k]``
    is the range in metres to the nearest obstacle there and ``obstacle_ids[k]`` its id (both
    ``None``: no obstacle reported in that sector).
    """

    sector_deg: float
    first_bearing_deg: float
    ranges_m: tuple[float | None, ...]
    obstacle_ids: tuple[int | None, ...]

    def __post_init__(self) -> None:
        if len(self.ranges_m) != len(self.obstacle_ids):
            raise InvalidInputError(f"ranges_m ({len(self.ranges_m)}) and obstacle_ids ({len(self.obstacle_ids)}) "
                                    f"must have one value per sector")

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


def sector_of_columns(width_px: int, calibration: StereoCalibration, sector_deg: float) -> tuple[np.ndarray, float]:
    """The sector of each image column (``int64 (width_px,)``, from 0) and the bearing where
    sector 0 begins (degrees, a whole multiple of ``sector_deg``)."""
    if not (math.isfinite(sector_deg) and 0 < sector_deg <= 180):
        raise InvalidInputError(f"sector_deg must be a number of degrees in (0, 180], got {sector_deg}")
    bearings = np.degrees(np.arctan2(np.arange(width_px) - calibration.cx_px, calibration.focal_px))
    first = math.floor(bearings[0] / sector_deg) * sector_deg
    return np.floor((bearings - first) / sector_deg).astype(np.int64), first


def direction_scan(id_map: np.ndarray, disparity: np.ndarray, calibration: StereoCalibration, *,
                   sector_deg: float, min_pixels: int, percentile: float) -> DirectionScan:
    """The scan of the module docstring.

    Parameters
    ----------
    id_map
        ``int (H, W)``: the obstacle each pixel belongs to, 0 for none.
    disparity
        ``float32 (H, W)`` disparity in pixels, NaN where unmatched (pixels without a depth,
        ``disparity + doffs <= 0``, are left out).
    calibration
        The rectified calibration the obstacles were measured with.
    sector_deg
        Width of a sector, degrees of bearing.
    min_pixels
        Pixels of known depth an obstacle needs in a sector to count there.
    percentile
        Percentile (0-100) of an obstacle's pixel ranges in a sector taken as its range there.
    """
    id_map = np.asarray(id_map)
    d = np.asarray(disparity)
    if id_map.ndim != 2 or id_map.shape != d.shape:
        raise InvalidInputError(f"id_map {id_map.shape} and disparity {d.shape} must be the same 2-D shape")
    if not 0 <= percentile <= 100:
        raise InvalidInputError(f"percentile must lie in [0, 100], got {percentile}")
    if not (isinstance(min_pixels, (int, np.integer)) and min_pixels >= 1):
        raise InvalidInputError(f"min_pixels must be an integer >= 1, got {min_pixels!r}")
    sector_of, first = sector_of_columns(id_map.shape[1], calibration, sector_deg)
    best, best_id = sector_ranges_kernel(np.ascontiguousarray(id_map, dtype=np.int32),
                                         np.ascontiguousarray(d, dtype=np.float32), sector_of,
                                         int(sector_of[-1]) + 1, float(calibration.cx_px),
                                         float(calibration.focal_px), float(calibration.focal_baseline_px_m),
                                         float(calibration.doffs_px), int(min_pixels), float(percentile))
    return DirectionScan(sector_deg=float(sector_deg), first_bearing_deg=float(first),
                         ranges_m=tuple(None if math.isnan(r) else round(float(r), 3) for r in best),
                         obstacle_ids=tuple(int(i) if i > 0 else None for i in best_id))
