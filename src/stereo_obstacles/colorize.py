"""Pictures of disparity and depth maps: turbo for disparity, magma for depth, invalid black.

Ranges are fixed by the caller (or taken from the valid values) so that pictures of one
sequence are comparable. Output is RGB ``uint8`` like every image in this package.
"""

from __future__ import annotations

import cv2
import numpy as np

from stereo_obstacles.errors import InvalidInputError

__all__ = ["color_bar", "colorize_depth", "colorize_disparity"]


def _colorize(values: np.ndarray, vmin: float, vmax: float, colormap: int, name: str) -> np.ndarray:
    a = np.asarray(values, np.float32)
    if a.ndim != 2:
        raise InvalidInputError(f"{name}: expected a 2-D map, got shape {a.shape}")
    if not (np.isfinite(vmin) and np.isfinite(vmax)) or vmax <= vmin:
        raise InvalidInputError(f"{name}: expected a finite range with vmin < vmax, got [{vmin}, {vmax}]")
    valid = np.isfinite(a)
    scaled = np.zeros(a.shape, np.uint8)
    scaled[valid] = np.clip(np.rint((a[valid] - vmin) * (255.0 / (vmax - vmin))), 0, 255).astype(np.uint8)
    rgb = cv2.cvtColor(cv2.applyColorMap(scaled, colormap), cv2.COLOR_BGR2RGB)
    rgb[~valid] = 0
    return rgb


def _valid_range(a: np.ndarray) -> tuple[float, float]:
    finite = np.asarray(a, np.float32)
    finite = finite[np.isfinite(finite)]
    if finite.size == 0:
        return 0.0, 1.0
    lo, hi = float(finite.min()), float(finite.max())
    return (lo, hi) if hi > lo else (lo, lo + 1.0)


def colorize_disparity(disparity: np.ndarray, vmin: float | None = None, vmax: float | None = None) -> np.ndarray:
    """Turbo picture of a disparity map (pixels); NaN/inf pixels black.

    Parameters
    ----------
    disparity : ndarray, shape (H, W)
    vmin, vmax : float, optional
        Disparities mapped to the ends of the colour map (default: the valid range).

    Returns
    -------
    ndarray of uint8, shape (H, W, 3), RGB

    Examples
    --------
    >>> import numpy as np
    >>> colorize_disparity(np.array([[np.nan, 1.0, 2.0]])).shape
    (1, 3, 3)
    """
    lo, hi = _valid_range(disparity)
    return _colorize(disparity, lo if vmin is None else vmin, hi if vmax is None else vmax,
                     cv2.COLORMAP_TURBO, "disparity")


def colorize_depth(depth_m: np.ndarray, max_m: float) -> np.ndarray:
    """Magma picture of a depth map: near bright, far (>= ``max_m`` metres) dark; invalid black."""
    if not max_m > 0:
        raise InvalidInputError(f"max_m: expected > 0, got {max_m}")
    near_is_high = max_m - np.asarray(depth_m, np.float32)
    return _colorize(near_is_high, 0.0, float(max_m), cv2.COLORMAP_MAGMA, "depth_m")


def color_bar(vmin: float, vmax: float, *, colormap: str = "turbo", height: int = 256, width: int = 24) -> np.ndarray:
    """Vertical colour bar, ``vmax`` at the top, as RGB ``uint8`` of shape ``(height, width, 3)``."""
    maps = {"turbo": cv2.COLORMAP_TURBO, "magma": cv2.COLORMAP_MAGMA}
    if colormap not in maps:
        raise InvalidInputError(f"colormap: expected one of {sorted(maps)}, got {colormap!r}")
    if height < 2 or width < 1:
        raise InvalidInputError(f"height, width: expected >= 2 and >= 1, got {height}, {width}")
    column = np.linspace(vmax, vmin, height, dtype=np.float32)[:, None]
    return _colorize(np.repeat(column, width, axis=1), vmin, vmax, maps[colormap], "color bar")
