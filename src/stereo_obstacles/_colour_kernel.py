"""Compiled per-pixel HSI formulas, shared by :mod:`stereo_obstacles.colour` and the segmentation.

The hue is the angle of the chromaticity vector ``(2R - G - B, sqrt(3) (G - B))``; this is
algebraically the same angle as the textbook arccos formula of the HSI model (Gonzalez &
Woods), without its division by a vanishing norm for grey pixels.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_SQRT3 = math.sqrt(3.0)


@njit(cache=True, inline="always")
def hsi_pixel(r, g, b, inv_full_scale):
    """Intensity in [0, 1], saturation in [0, 1] and the chromaticity vector of one pixel.

    ``r, g, b`` are raw channel values; ``inv_full_scale`` is ``1 / max value of the dtype``.
    Returns ``(intensity, saturation, chroma_x, chroma_y)``; the chroma is in raw units.
    """
    fr = np.float32(r)
    fg = np.float32(g)
    fb = np.float32(b)
    total = fr + fg + fb
    intensity = total * np.float32(inv_full_scale / 3.0)
    smallest = min(fr, fg, fb)
    saturation = np.float32(0.0)
    if total > 0.0:
        saturation = np.float32(1.0) - np.float32(3.0) * smallest / total
    chroma_x = np.float32(2.0) * fr - fg - fb
    chroma_y = np.float32(_SQRT3) * (fg - fb)
    return intensity, saturation, chroma_x, chroma_y


@njit(cache=True, nogil=True)
def rgb_to_hsi_kernel(rgb, inv_full_scale, min_intensity, min_saturation, hue, saturation,
                      intensity):
    """Fill ``hue`` (degrees, NaN if invalid), ``saturation`` (NaN if invalid) and ``intensity``."""
    height, width = rgb.shape[0], rgb.shape[1]
    nan = np.float32(np.nan)
    to_degrees = np.float32(180.0 / math.pi)
    for y in range(height):
        for x in range(width):
            i, s, cx, cy = hsi_pixel(rgb[y, x, 0], rgb[y, x, 1], rgb[y, x, 2], inv_full_scale)
            intensity[y, x] = i
            if i < min_intensity:
                saturation[y, x] = nan
                hue[y, x] = nan
                continue
            saturation[y, x] = s
            if s < min_saturation:
                hue[y, x] = nan
                continue
            h = math.atan2(cy, cx) * to_degrees
            if h < 0.0:
                h += np.float32(360.0)
            if h >= np.float32(360.0):  # -0 or rounding just below 0
                h = np.float32(0.0)
            hue[y, x] = h
