"""Subpixel disparity: a parabola through the similarity at ``d - 1``, ``d`` and ``d + 1``.

Not part of the published GCS; depth accuracy needs it. Where the three values do not form
a peak (the parabola opens upwards or is flat) or a side value is missing, the integer
disparity is kept. The offset is clamped to ``[-0.5, 0.5]`` pixel.
"""

from __future__ import annotations

import numpy as np

__all__ = ["parabola_offset"]


def parabola_offset(c_minus: np.ndarray, c0: np.ndarray, c_plus: np.ndarray) -> np.ndarray:
    """Offset in pixels of the vertex of the parabola through ``(-1, c_minus), (0, c0), (1, c_plus)``.

    Parameters
    ----------
    c_minus, c0, c_plus : ndarray of float, same shape
        Similarity at ``d - 1``, ``d`` and ``d + 1``; NaN where unknown.

    Returns
    -------
    ndarray of float32
        In ``[-0.5, 0.5]``; 0 where there is no peak or a value is NaN.

    Examples
    --------
    >>> import numpy as np
    >>> float(parabola_offset(np.array(0.5), np.array(1.0), np.array(0.5)))
    0.0
    >>> float(parabola_offset(np.array(0.0), np.array(1.0), np.array(1.0)))
    0.5
    """
    cm = np.asarray(c_minus, np.float64)
    c = np.asarray(c0, np.float64)
    cp = np.asarray(c_plus, np.float64)
    curvature = cm - 2.0 * c + cp
    peak = np.isfinite(curvature) & (curvature < 0.0)
    safe = np.where(peak, curvature, -1.0)
    offset = np.where(peak, 0.5 * (cm - cp) / safe, 0.0)
    return np.clip(np.nan_to_num(offset), -0.5, 0.5).astype(np.float32)
