"""Compiled passes of the shadow texture test (private; see :mod:`stereo_obstacles.shadow_texture`)."""

from __future__ import annotations

import numpy as np
from numba import njit

from stereo_obstacles._similarity_kernel import CACHE


@njit(cache=CACHE, nogil=True, inline="always")
def _reflect(i, n):
    """Index ``i`` of a sequence of ``n >= 1`` mirrored at both ends with the edge repeated
    (OpenCV's ``BORDER_REFLECT``: ``-1 -> 0``, ``n -> n - 1``), as often as needed when ``i``
    lies more than ``n`` outside (a window wider than the image)."""
    while i < 0 or i >= n:
        i = -i - 1 if i < 0 else 2 * n - 1 - i
    return i


@njit(cache=CACHE, nogil=True)
def sampled_square_means_kernel(values, window, step, out):
    """Mean of ``values ** 2`` over the ``window`` square centred on every ``step``-th row and
    column (starting at 0), mirrored at the image border (``BORDER_REFLECT``).

    ``values``: ``float32 (H, W)``; ``out``: ``float64 (ceil(H / step), ceil(W / step))``.
    The same numbers as ``cv2.blur(values ** 2, (window, window), borderType=cv2.BORDER_REFLECT)
    [::step, ::step]`` up to rounding, without the work on the rows and columns not sampled.
    """
    height, width = values.shape
    r = window // 2
    columns = np.empty(width, dtype=np.float64)
    scale = 1.0 / (window * window)
    for i in range(out.shape[0]):
        y = i * step
        columns[:] = 0.0
        for k in range(-r, r + 1):
            row = values[_reflect(y + k, height)]
            for x in range(width):
                columns[x] += row[x] * row[x]
        for j in range(out.shape[1]):
            x = j * step
            total = 0.0
            for k in range(-r, r + 1):
                total += columns[_reflect(x + k, width)]
            out[i, j] = total * scale


@njit(cache=CACHE, nogil=True)
def relative_texture_kernel(mean, mean_square, noise, variance, relative):
    """``variance = max(mean_square - mean^2 - noise, 0)`` and ``relative = sqrt(variance) /
    max(mean, 1)``, all ``float32 (H, W)`` (``mean``, ``mean_square``: window means of a grey
    image and of its square; ``noise``: a variance in the same units)."""
    height, width = mean.shape
    for y in range(height):
        for x in range(width):
            m = mean[y, x]
            v = max(mean_square[y, x] - m * m - noise, np.float32(0.0))
            variance[y, x] = v
            relative[y, x] = np.sqrt(v) / max(m, np.float32(1.0))
