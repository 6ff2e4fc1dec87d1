"""The one check every stereo stage makes first: the two images of a pair have one size."""

from __future__ import annotations

import numpy as np

from stereo_obstacles.errors import ImageMismatchError


def check_same_size(left: np.ndarray, right: np.ndarray) -> None:
    """Raise :class:`ImageMismatchError` when ``left`` and ``right`` differ in height or width.

    Both are arrays of shape ``(H, W)`` or ``(H, W, C)``; channels are not compared.
    """
    if left.shape[:2] != right.shape[:2]:
        raise ImageMismatchError(f"left and right images differ in size: {left.shape[1]}x{left.shape[0]} "
                                 f"and {right.shape[1]}x{right.shape[0]}")
