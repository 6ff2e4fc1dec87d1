"""How well a pair is rectified: the vertical offsets of corresponding points, in pixels.

In a rectified pair a left point ``(x, y)`` and its right correspondence ``(x', y')`` share
the row, ``y' = y``. :func:`vertical_offset_stats` summarises ``|y - y'|`` over a set of
correspondences (chessboard corners, feature matches, exact synthetic correspondences).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from stereo_obstacles.errors import InvalidInputError


@dataclass(frozen=True)
class VerticalOffsetStats:
    """Summary of ``|y_left - y_right|`` over corresponding points.

    Attributes
    ----------
    n_points : int
        Correspondences summarised.
    median_px, p95_px, max_px : float
        Median, 95th percentile and largest absolute vertical offset, pixels (NaN without points).
    mean_signed_px : float
        Mean of ``y_left - y_right`` (a constant vertical shift shows here), pixels.
    """

    n_points: int
    median_px: float
    p95_px: float
    max_px: float
    mean_signed_px: float

    def __post_init__(self) -> None:
        if self.n_points < 0:
            raise InvalidInputError(f"n_points must be >= 0, got {self.n_points}")

    def to_dict(self) -> dict:
        """JSON-ready mapping (NaN becomes ``None``)."""
        return {k: (None if isinstance(v, float) and math.isnan(v) else v) for k, v in asdict(self).items()}

    def describe(self) -> str:
        """One line for people: ``median 0.12 px, 95th percentile 0.40 px over 812 points``."""
        return (f"vertical offset median {self.median_px:.3f} px, 95th percentile {self.p95_px:.3f} px, "
                f"max {self.max_px:.3f} px over {self.n_points} points")


def vertical_offset_stats(left_px: np.ndarray, right_px: np.ndarray) -> VerticalOffsetStats:
    """Vertical offsets of corresponding points.

    Parameters
    ----------
    left_px, right_px : ndarray, shape (N, 2)
        ``(x, y)`` pixel coordinates of corresponding points in the left and right images.

    Returns
    -------
    VerticalOffsetStats

    Raises
    ------
    InvalidInputError
        The arrays are not ``(N, 2)`` of one length.

    Examples
    --------
    >>> import numpy as np
    >>> vertical_offset_stats(np.array([[10.0, 5.0], [20.0, 7.0]]), np.array([[4.0, 5.5], [9.0, 7.5]])).median_px
    0.5
    """
    left = np.asarray(left_px, dtype=np.float64)
    right = np.asarray(right_px, dtype=np.float64)
    if left.ndim != 2 or left.shape[1] != 2 or left.shape != right.shape:
        raise InvalidInputError(f"left_px, right_px: expected two (N, 2) arrays of one shape, got "
                                f"{left.shape} and {right.shape}")
    signed = left[:, 1] - right[:, 1]
    if signed.size == 0:
        nan = float("nan")
        return VerticalOffsetStats(0, nan, nan, nan, nan)
    offsets = np.abs(signed)
    return VerticalOffsetStats(n_points=int(offsets.size), median_px=float(np.median(offsets)),
                               p95_px=float(np.percentile(offsets, 95)), max_px=float(offsets.max()),
                               mean_signed_px=float(signed.mean()))
