"""RGB to HSI (hue, saturation, intensity) conversion with validity masks.

The HSI model of the paper (and of Gonzalez & Woods): intensity ``I = (R + G + B) / 3``,
saturation ``S = 1 - min(R, G, B) / I``, hue the angle of the colour around the grey axis,
0 degrees = red, 120 = green, 240 = blue. Colour is noisy in dark pixels and hue is
meaningless in grey ones, so:

* saturation (and hue) are valid only where ``I >= min_intensity``;
* hue is valid only where, in addition, ``S >= min_saturation``.

Invalid values are NaN. Intensity is a fraction of the dtype's full scale (255 for ``uint8``,
65535 for ``uint16``), so thresholds do not depend on the bit depth.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stereo_obstacles._colour_kernel import rgb_to_hsi_kernel
from stereo_obstacles.errors import InvalidInputError

DEFAULT_MIN_INTENSITY = 0.05
"""Default ``min_intensity``: 5 % of full scale (about 13/255); below it colour is mostly noise."""

DEFAULT_MIN_SATURATION = 0.08
"""Default ``min_saturation``: below 8 % saturation (a grey pixel) hue is not trusted."""


@dataclass(frozen=True, eq=False)
class HSI:
    """An image in HSI.

    Attributes
    ----------
    hue
        ``float32 (H, W)``, degrees in ``[0, 360)``; NaN where hue is not valid.
    saturation
        ``float32 (H, W)`` in ``[0, 1]``; NaN where the pixel is too dark.
    intensity
        ``float32 (H, W)`` in ``[0, 1]`` (fraction of the dtype's full scale); always valid.
    min_intensity, min_saturation
        The validity thresholds used (fractions of full scale, and of 1).
    """

    hue: np.ndarray
    saturation: np.ndarray
    intensity: np.ndarray
    min_intensity: float
    min_saturation: float

    def __post_init__(self) -> None:
        shape = self.intensity.shape
        for name in ("hue", "saturation", "intensity"):
            a = getattr(self, name)
            if a.dtype != np.float32 or a.shape != shape or a.ndim != 2:
                raise InvalidInputError(f"HSI.{name} must be float32 {shape}, got {a.dtype} {a.shape}")

    @property
    def hue_valid(self) -> np.ndarray:
        """``bool (H, W)``: intensity and saturation high enough for a meaningful hue."""
        return ~np.isnan(self.hue)

    @property
    def saturation_valid(self) -> np.ndarray:
        """``bool (H, W)``: intensity high enough for a meaningful saturation."""
        return ~np.isnan(self.saturation)


def check_rgb(rgb: np.ndarray, name: str = "rgb") -> tuple[np.ndarray, float]:
    """Validate a colour image; return it C-contiguous and the reciprocal of its full scale.

    Raises
    ------
    InvalidInputError
        Not a ``uint8``/``uint16`` array of shape ``(H, W, 3)`` with ``H, W >= 1``.
    """
    a = np.asarray(rgb)
    if a.ndim != 3 or a.shape[2] != 3 or a.shape[0] < 1 or a.shape[1] < 1:
        raise InvalidInputError(f"{name} must have shape (H, W, 3), got {a.shape}")
    if a.dtype not in (np.uint8, np.uint16):
        raise InvalidInputError(f"{name} must be uint8 or uint16, got {a.dtype}")
    return np.ascontiguousarray(a), 1.0 / float(np.iinfo(a.dtype).max)


def check_thresholds(min_intensity: float, min_saturation: float) -> None:
    """Raise :class:`InvalidInputError` unless both thresholds are finite and in ``[0, 1]``."""
    for name, value in (("min_intensity", min_intensity), ("min_saturation", min_saturation)):
        if not (np.isfinite(value) and 0.0 <= value <= 1.0):
            raise InvalidInputError(f"{name} must be in [0, 1], got {value!r}")


def rgb_to_hsi(rgb: np.ndarray, *, min_intensity: float = DEFAULT_MIN_INTENSITY,
               min_saturation: float = DEFAULT_MIN_SATURATION) -> HSI:
    """Convert an RGB image to hue, saturation and intensity with validity masks.

    Parameters
    ----------
    rgb
        ``uint8`` or ``uint16`` array of shape ``(H, W, 3)``, RGB order.
    min_intensity
        Saturation and hue are NaN where intensity (fraction of full scale) is below this.
    min_saturation
        Hue is NaN where saturation is below this.

    Returns
    -------
    HSI
        Hue in degrees ``[0, 360)``, saturation and intensity in ``[0, 1]``, all ``float32``.

    Raises
    ------
    InvalidInputError
        Wrong shape or dtype, or a threshold outside ``[0, 1]``.

    Examples
    --------
    >>> import numpy as np
    >>> hsi = rgb_to_hsi(np.array([[[200, 100, 50]]], dtype=np.uint8))
    >>> round(float(hsi.hue[0, 0]), 2), round(float(hsi.saturation[0, 0]), 4)
    (19.11, 0.5714)
    """
    a, inv_full_scale = check_rgb(rgb)
    check_thresholds(min_intensity, min_saturation)
    shape = a.shape[:2]
    hue = np.empty(shape, dtype=np.float32)
    saturation = np.empty(shape, dtype=np.float32)
    intensity = np.empty(shape, dtype=np.float32)
    rgb_to_hsi_kernel(a, inv_full_scale, np.float32(min_intensity), np.float32(min_saturation),
                      hue, saturation, intensity)
    return HSI(hue=hue, saturation=saturation, intensity=intensity,
               min_intensity=float(min_intensity), min_saturation=float(min_saturation))


def hue_difference(a_deg: np.ndarray | float, b_deg: np.ndarray | float) -> np.ndarray:
    """Signed circular difference ``a - b`` wrapped to ``[-180, 180)`` degrees (NaN stays NaN)."""
    d = np.asarray(a_deg, dtype=np.float64) - np.asarray(b_deg, dtype=np.float64)
    return (d + 180.0) % 360.0 - 180.0


__all__ = ["HSI", "DEFAULT_MIN_INTENSITY", "DEFAULT_MIN_SATURATION", "rgb_to_hsi",
           "hue_difference", "check_rgb", "check_thresholds"]
