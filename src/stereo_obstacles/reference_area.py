"""The reference area: a rectangle in front of the walker assumed to be ground, and its statistics.

The paper takes the mean hue and intensity (and the intensity range) of a rectangle at the
bottom centre of the image. A plain mean is broken by a small obstacle or a shadow inside
the rectangle, and a plain mean of hue angles is wrong across 0/360. Here:

* hue: circular mean as a start, then the median of the hue differences to it (a circular
  median); pixels farther than ``outlier_mads`` robust deviations (1.4826 MAD) are rejected;
* the hue spread is the ``100 - spread_percentile`` percentile of the remaining pixels'
  circular distance to the median hue, and the hue threshold is ``hue_threshold_factor``
  times it (the paper's "20 % of the hue difference in the reference area" is far too tight
  once the hue is median-filtered: see docs/segmentation.md), clipped to an interval;
* intensity: median and MAD over the colour-consistent pixels, outliers rejected the same
  way (a shadow or a dark object inside the rectangle), then a percentile range;
* grey ground (asphalt, concrete: fewer than ``min_hue_fraction`` of the pixels have a hue)
  is described by its saturation instead of its hue, and cleaned by saturation outliers.

An unusable area (too few pixels bright enough to measure colour, or too few left after
rejection) raises :class:`~stereo_obstacles.errors.InvalidInputError`; a suspicious one (most
pixels rejected, or a very wide hue or intensity spread) is logged as a warning.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from stereo_obstacles.colour import HSI, hue_difference
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import check_integers, check_numbers, check_positive, is_finite_real, plain_numbers
from stereo_obstacles.quantiles import MAD_TO_SIGMA, median, percentile, percentiles

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class ReferenceArea:
    """A rectangle ``[x0, x1) x [y0, y1)``, in pixels or in fractions of the image size.

    Parameters
    ----------
    x0, y0, x1, y1
        Corners; ``x0 < x1`` and ``y0 < y1``.
    unit
        ``"fraction"`` (0..1 of width and height) or ``"px"``.
    """

    x0: float
    y0: float
    x1: float
    y1: float
    unit: str = "fraction"

    def __post_init__(self) -> None:
        if self.unit not in ("fraction", "px"):
            raise InvalidInputError(f"reference unit must be 'fraction' or 'px', got {self.unit!r}")
        plain_numbers(self)                      # NumPy scalars as Python numbers (JSON-ready)
        corners = (self.x0, self.y0, self.x1, self.y1)
        if not all(is_finite_real(v) for v in corners):
            raise InvalidInputError(f"reference corners must be finite numbers, got {corners}")
        if not (self.x0 < self.x1 and self.y0 < self.y1):
            raise InvalidInputError(f"reference needs x0 < x1 and y0 < y1, got {corners}")
        if min(corners) < 0 or (self.unit == "fraction" and max(corners) > 1):
            raise InvalidInputError(f"reference corners out of range for unit {self.unit!r}: {corners}")

    @classmethod
    def parse(cls, text: str) -> ReferenceArea:
        """Parse ``"x0,y0,x1,y1"``: fractions of the image when every value is <= 1, else whole
        pixels (a value with a fraction beside one above 1 is a mistake, e.g. ``0,0.85,1,1.5``)."""
        parts = text.split(",")
        try:
            values = [float(p) for p in parts]
        except ValueError:
            values = []
        if len(values) != 4:
            raise InvalidInputError(f"reference must be x0,y0,x1,y1 (pixels or fractions), got {text!r}")
        unit = "fraction" if max(values) <= 1.0 else "px"
        if unit == "px" and not all(v == math.floor(v) for v in values if math.isfinite(v)):
            if any(0 < v < 1 for v in values):
                raise InvalidInputError(f"reference {text} mixes fractions of the image (all four <= 1) and pixels "
                                        f"(whole numbers); give all four one way")
            raise InvalidInputError(f"reference {text}: corners in pixels must be whole numbers")
        return cls(*values, unit=unit)

    def __str__(self) -> str:
        corners = ",".join(f"{v:g}" for v in (self.x0, self.y0, self.x1, self.y1))
        return f"{corners} ({'fractions of the image' if self.unit == 'fraction' else 'pixels'})"

    def to_pixels(self, height: int, width: int) -> tuple[int, int, int, int]:
        """Integer pixel bounds ``(x0, y0, x1, y1)`` (half-open) inside a ``height x width`` image.

        Raises
        ------
        InvalidInputError
            The rectangle is empty or outside the image.
        """
        if self.unit == "fraction":
            box = (round(self.x0 * width), round(self.y0 * height),
                   round(self.x1 * width), round(self.y1 * height))
        else:
            box = (int(self.x0), int(self.y0), int(math.ceil(self.x1)), int(math.ceil(self.y1)))
        x0, y0, x1, y1 = box
        x1, y1 = min(x1, width), min(y1, height)
        if x1 <= x0 or y1 <= y0:
            raise InvalidInputError(f"reference area {self} is empty in a {width}x{height} image")
        if (x1, y1) != box[2:]:                 # pixels given for another image size?
            logger.warning("reference area %s reaches past the %dx%d image: (%d, %d, %d, %d) is used", self, width,
                           height, x0, y0, x1, y1)
        return x0, y0, x1, y1


DEFAULT_REFERENCE_AREA = ReferenceArea(0.0, 0.85, 1.0, 1.0)
"""The lowest 15 % of the image, full width: the ground right in front of the walker. The
``"log_rgb"`` colour model cuts it into strips and keeps the colours most strips agree on, so
an obstacle standing in part of it does not become ground (docs/segmentation.md)."""


@dataclass(frozen=True)
class ReferenceParameters:
    """How the reference statistics are made robust; every field is a documented threshold.

    Attributes
    ----------
    min_valid_fraction
        Error when fewer than this fraction of the area's pixels are bright enough to measure
        colour (``intensity >= min_intensity``).
    min_pixels
        Error when fewer pixels than this remain for the statistics.
    min_hue_fraction
        Below this fraction of pixels with a valid hue the ground is treated as grey.
    outlier_mads
        Pixels farther than this many robust standard deviations from the median (hue, then
        intensity) are rejected as not ground (an object or a shadow inside the area).
    min_outlier_hue_deg, min_outlier_intensity, min_outlier_saturation
        Floors of those rejection distances, so that a perfectly uniform area rejects nothing
        of its noise: degrees, fraction of full scale, and saturation (grey ground is
        cleaned by saturation, as coloured ground is by hue).
    spread_percentile
        The hue spread is the ``100 -`` this percentile of the kept pixels' hue distance to
        the median; the intensity range runs from this percentile to ``100 -`` it.
    hue_threshold_factor
        Hue threshold = this times the hue spread (measured default; docs/segmentation.md).
    min_hue_threshold_deg, max_hue_threshold_deg
        Clip of the hue threshold, degrees.
    saturation_margin
        Grey ground: a pixel matches when its saturation is at most the area's upper
        saturation percentile plus this.
    warn_kept_fraction
        Warn when fewer than this fraction of measurable pixels survive rejection.
    warn_hue_spread_deg, warn_intensity_spread
        Warn when the hue spread (degrees) or the relative intensity range
        ``(high - low) / median`` exceeds these: the area is too varied to be one ground.
    """

    min_valid_fraction: float = 0.3
    min_pixels: int = 30
    min_hue_fraction: float = 0.5
    outlier_mads: float = 3.0
    min_outlier_hue_deg: float = 3.0
    min_outlier_intensity: float = 0.02
    min_outlier_saturation: float = 0.03
    spread_percentile: float = 1.0
    hue_threshold_factor: float = 1.0
    min_hue_threshold_deg: float = 4.0
    max_hue_threshold_deg: float = 45.0
    saturation_margin: float = 0.03
    warn_kept_fraction: float = 0.5
    warn_hue_spread_deg: float = 90.0
    warn_intensity_spread: float = 1.0
    max_samples: int = 12000

    def __post_init__(self) -> None:
        check_numbers(self, tuple((name, 0.0, 1.0) for name in (
            "min_valid_fraction", "min_hue_fraction", "warn_kept_fraction", "saturation_margin",
            "min_outlier_intensity", "min_outlier_saturation")))
        check_positive(self, ("outlier_mads", "hue_threshold_factor", "warn_hue_spread_deg", "warn_intensity_spread"))
        check_numbers(self, (("spread_percentile", 0.0, 50.0), ("min_outlier_hue_deg", 0.0, 180.0),
                             ("min_hue_threshold_deg", 0.0, 180.0), ("max_hue_threshold_deg", 0.0, 180.0)))
        if self.spread_percentile == 50.0:
            raise InvalidInputError("spread_percentile must be below 50 (the spread would be 0), got 50.0")
        if self.min_hue_threshold_deg > self.max_hue_threshold_deg:
            raise InvalidInputError("need min_hue_threshold_deg <= max_hue_threshold_deg, got "
                                    f"{self.min_hue_threshold_deg!r} and {self.max_hue_threshold_deg!r}")
        check_integers(self, (("min_pixels", 1, math.inf), ("max_samples", 1, math.inf)))

    def sample_step(self, height: int, width: int) -> int:
        """Smallest row and column step leaving at most ``max_samples`` pixels of an area.

        Examples
        --------
        >>> ReferenceParameters().sample_step(72, 640), ReferenceParameters().sample_step(9, 80)
        (2, 1)
        """
        step = 1
        while math.ceil(height / step) * math.ceil(width / step) > self.max_samples:
            step += 1
        return step


@dataclass(frozen=True)
class ReferenceStatistics:
    """What the ground looks like, measured in the reference area.

    Attributes
    ----------
    box_px
        ``(x0, y0, x1, y1)`` of the area in pixels, half-open.
    hue_deg
        Circular median hue of the ground, degrees in ``[0, 360)``; None for grey ground.
    hue_spread_deg
        Robust hue spread: high percentile of the kept pixels' distance to ``hue_deg``,
        degrees (0 for grey ground).
    hue_threshold_deg
        Hue threshold used by the classifier, degrees (0 for grey ground).
    max_saturation
        Grey ground: saturation up to which a pixel matches (None for coloured ground).
    intensity_median, intensity_low, intensity_high
        Median and robust range of ground intensity, fractions of full scale.
    rgb_median
        Per-channel median colour of the kept pixels, fractions of full scale.
    n_pixels, n_measurable, n_kept
        Pixels sampled from the area (:meth:`ReferenceParameters.sample_step`), those bright
        enough to measure colour, those kept after rejection.
    """

    box_px: tuple[int, int, int, int]
    hue_deg: float | None
    hue_spread_deg: float
    hue_threshold_deg: float
    max_saturation: float | None
    intensity_median: float
    intensity_low: float
    intensity_high: float
    rgb_median: tuple[float, float, float]
    n_pixels: int
    n_measurable: int
    n_kept: int

    def __post_init__(self) -> None:
        if (self.hue_deg is None) == (self.max_saturation is None):
            raise InvalidInputError("exactly one of hue_deg (coloured ground) and max_saturation "
                                    "(grey ground) must be set")
        if not 0.0 < self.intensity_median <= 1.0:
            raise InvalidInputError(f"intensity_median must be in (0, 1], got {self.intensity_median!r}")
        if not self.intensity_low <= self.intensity_median <= self.intensity_high:
            raise InvalidInputError("need intensity_low <= intensity_median <= intensity_high, got "
                                    f"{self.intensity_low}, {self.intensity_median}, {self.intensity_high}")

    @property
    def is_grey(self) -> bool:
        """True when the ground has too little colour for a hue and saturation is used instead."""
        return self.hue_deg is None

    def as_dict(self) -> dict:
        """JSON-ready dictionary of the statistics."""
        return {"box_px": list(self.box_px), "hue_deg": self.hue_deg,
                "hue_spread_deg": self.hue_spread_deg, "hue_threshold_deg": self.hue_threshold_deg,
                "max_saturation": self.max_saturation, "intensity_median": self.intensity_median,
                "intensity_low": self.intensity_low, "intensity_high": self.intensity_high,
                "rgb_median": list(self.rgb_median),
                "n_pixels": self.n_pixels, "n_measurable": self.n_measurable, "n_kept": self.n_kept}


def circular_median_deg(hue_deg: np.ndarray) -> float:
    """Circular median of angles in degrees (1-D, no NaN), in ``[0, 360)``.

    The median of the differences to the circular mean, added back to it: exact whenever
    the angles lie within a half circle around their mean, which is the case for ground.
    """
    h = np.asarray(hue_deg, dtype=np.float64)
    if h.ndim != 1 or h.size == 0 or not np.all(np.isfinite(h)):
        raise InvalidInputError(f"hue_deg must be a non-empty 1-D array without NaN, got shape {h.shape}")
    radians = np.deg2rad(h)
    mean = math.degrees(math.atan2(float(np.sin(radians).mean()), float(np.cos(radians).mean())))
    return float((mean + median(hue_difference(h, mean))) % 360.0)


def _keep_close(values: np.ndarray, centre: float, floor: float, mads: float) -> np.ndarray:
    deviation = np.abs(values - centre)
    limit = max(floor, mads * MAD_TO_SIGMA * median(deviation))
    return deviation <= limit


def reference_statistics(rgb: np.ndarray, hsi: HSI, box_px: tuple[int, int, int, int], *,
                         params: ReferenceParameters = ReferenceParameters()) -> ReferenceStatistics:
    """Robust statistics of the ground in the reference area.

    Parameters
    ----------
    rgb
        The reference area (the crop ``image[y0:y1, x0:x1]``), ``uint8``/``uint16 (h, w, 3)``.
    hsi
        Its HSI (:func:`~stereo_obstacles.colour.rgb_to_hsi` of ``rgb``).
    box_px
        ``(x0, y0, x1, y1)`` of the crop in the full image, for the record and messages.
    params
        Robustness thresholds.

    Returns
    -------
    ReferenceStatistics

    Raises
    ------
    InvalidInputError
        Too few measurable pixels (too dark) or too few left after outlier rejection.
    """
    if rgb.shape[:2] != hsi.intensity.shape or rgb.ndim != 3:
        raise InvalidInputError(f"rgb {rgb.shape} and hsi {hsi.intensity.shape} must cover the same area")
    hue = hsi.hue.ravel()
    saturation = hsi.saturation.ravel()
    intensity = hsi.intensity.ravel()
    n_pixels = intensity.size
    if n_pixels < params.min_pixels:
        raise InvalidInputError(f"reference area {box_px} holds only {n_pixels} pixels; it needs at least "
                                f"{params.min_pixels}: choose a larger area (--reference, or a ReferenceArea)")
    measurable = ~np.isnan(saturation)
    n_measurable = int(measurable.sum())
    if n_measurable < max(params.min_pixels, params.min_valid_fraction * n_pixels):
        raise InvalidInputError(
            f"reference area {box_px} is unusable: only {n_measurable} of {n_pixels} pixels are "
            f"bright enough to measure colour (intensity >= {hsi.min_intensity}); need "
            f"{params.min_valid_fraction:.0%} and at least {params.min_pixels}. Choose another "
            f"area (--reference, or a ReferenceArea) or check the exposure")
    hue_valid = ~np.isnan(hue)
    grey = hue_valid.sum() < params.min_hue_fraction * n_measurable
    if grey:
        keep = measurable.copy()
        keep[measurable] = _keep_close(saturation[measurable], median(saturation[measurable]),
                                       params.min_outlier_saturation, params.outlier_mads)
        hue_deg = None
        spread = threshold = 0.0
    else:
        hue_deg = circular_median_deg(hue[hue_valid])
        offsets = np.zeros(n_pixels)
        offsets[hue_valid] = hue_difference(hue[hue_valid], hue_deg)
        keep = hue_valid & _keep_close(offsets, 0.0, params.min_outlier_hue_deg, params.outlier_mads)
    if not keep.any():
        raise InvalidInputError(f"reference area {box_px} is unusable: no pixel is consistent with one "
                                f"ground (need {params.min_pixels})")
    intensity_keep = _keep_close(intensity[keep], median(intensity[keep]),
                                 params.min_outlier_intensity, params.outlier_mads)
    keep[np.flatnonzero(keep)[~intensity_keep]] = False
    n_kept = int(keep.sum())
    if n_kept < params.min_pixels:
        raise InvalidInputError(f"reference area {box_px} is unusable: only {n_kept} pixels are "
                                f"consistent with one ground (need {params.min_pixels})")
    q = params.spread_percentile
    kept_intensity = intensity[keep]
    low, middle, high = percentiles(kept_intensity, (q, 50.0, 100.0 - q))
    full_scale = float(np.iinfo(rgb.dtype).max)
    rgb_median = tuple(median(channel) / full_scale for channel in rgb.reshape(-1, 3)[keep].T)
    max_saturation = None
    if grey:
        max_saturation = min(1.0, percentile(saturation[keep], 100.0 - q)
                             + params.saturation_margin)
    else:
        spread = percentile(np.abs(offsets[keep]), 100.0 - q)
        threshold = float(np.clip(params.hue_threshold_factor * spread,
                                  params.min_hue_threshold_deg, params.max_hue_threshold_deg))
    if middle <= 0.0:
        raise InvalidInputError(f"reference area {box_px} is black (median intensity 0)")
    if n_kept < params.warn_kept_fraction * n_measurable:
        logger.warning("reference area %s: only %d of %d measurable pixels look like one ground; "
                       "an obstacle or a shadow may cover it", box_px, n_kept, n_measurable)
    if spread > params.warn_hue_spread_deg or (high - low) / middle > params.warn_intensity_spread:
        logger.warning("reference area %s is very varied (hue spread %.0f deg, intensity %.2f..%.2f); "
                       "the segmentation may be poor", box_px, spread, low, high)
    logger.debug("reference %s: hue %s, threshold %.1f deg, intensity %.3f [%.3f, %.3f]", box_px,
                 hue_deg, threshold, middle, low, high)
    return ReferenceStatistics(box_px=tuple(int(v) for v in box_px), hue_deg=hue_deg,
                               hue_spread_deg=spread, hue_threshold_deg=threshold,
                               max_saturation=max_saturation, intensity_median=middle,
                               intensity_low=low, intensity_high=high, rgb_median=rgb_median,
                               n_pixels=n_pixels,
                               n_measurable=n_measurable, n_kept=n_kept)


__all__ = ["ReferenceArea", "DEFAULT_REFERENCE_AREA", "ReferenceParameters", "ReferenceStatistics",
           "circular_median_deg", "reference_statistics"]
