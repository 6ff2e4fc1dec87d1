"""Validation of the float maps passed between stages (disparity, depth): one rule, one message."""

from __future__ import annotations

import numpy as np

from stereo_obstacles.errors import InvalidInputError


def check_float_map(array: np.ndarray, name: str) -> np.ndarray:
    """Return ``array`` as a NumPy array after checking it is a floating-point ``(H, W)`` map.

    Parameters
    ----------
    array : numpy.ndarray
        The map, shape ``(H, W)``, any floating dtype, NaN where invalid (units as the caller's).
    name : str
        Argument name used in the error message.

    Returns
    -------
    numpy.ndarray
        The same data (no copy, dtype unchanged).

    Raises
    ------
    InvalidInputError
        Not 2-D, or not floating point.

    Examples
    --------
    >>> check_float_map(np.zeros((2, 3), np.float32), "disparity").shape
    (2, 3)
    """
    a = np.asarray(array)
    if a.ndim != 2:
        raise InvalidInputError(f"{name} must be a 2-D (H, W) array, got shape {a.shape}")
    if not np.issubdtype(a.dtype, np.floating):
        raise InvalidInputError(f"{name} must be floating point with NaN for invalid, got {a.dtype}")
    return a


__all__ = ["check_float_map"]
