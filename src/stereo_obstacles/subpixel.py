"""Subpixel disparity: a parabola through the similarity at ``d - 1``, ``d`` and ``d + 1``.

Not part of the published GCS; depth accuracy needs it. Where the three values do not form
a peak (the parabola opens upwards or is flat) or a side value is missing, the integer
disparity is kept. The offset is clamped to ``[-0.5, 0.5]`` pixel.
"""

from __future__ import annotations

import numpy as np

from stereo_obstacles._subpixel_kernel import _parabola_offsets

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
    shape = np.broadcast_shapes(np.shape(c_minus), np.shape(c0), np.shape(c_plus))
    flat = [np.ascontiguousarray(np.broadcast_to(np.asarray(a, np.float64), shape)).ravel()
            for a in (c_minus, c0, c_plus)]
    return _parabola_offsets(*flat).reshape(shape)

