"""Regions of a disparity map, and speckle removal: small islands of disparity are dropped.

A wrong match rarely comes alone: the growth extends it into a small patch whose disparities
agree with each other but with nothing around them. A *region* is a set of matched pixels
connected through 4-neighbours whose disparities differ by at most ``max_difference_px``; a
region of at most ``max_size_px`` pixels is a speckle and is unmatched. This is the rule of
OpenCV's ``filterSpeckles`` (which the StereoSGBM peer applies with 100 px and 2 disparity
units), implemented here on float disparities. It is not part of the published GCS; its
measured effect on the Middlebury pairs is in ``docs/matching.md`` ("Speckle removal").
"""

from __future__ import annotations

import numpy as np

from stereo_obstacles._speckle_kernel import link_kernel, region_kernel, speckle_kernel
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import is_finite_real, is_whole_number

__all__ = ["disparity_regions", "speckle_mask"]


def speckle_mask(disparity: np.ndarray, *, max_size_px: int, max_difference_px: float) -> np.ndarray:
    """``bool (H, W)``: the matched pixels that belong to a speckle.

    Parameters
    ----------
    disparity : ndarray of float, shape (H, W)
        Disparity map in pixels, NaN (or any non-finite value) where unmatched (float16 maps
        are read as float32). Disparity steps are computed and compared in float64.
    max_size_px : int
        Regions of at most this many pixels are speckles (>= 0; 0 finds none).
    max_difference_px : float
        Neighbours whose disparities differ by at most this, pixels, are in the same region (>= 0).

    Returns
    -------
    ndarray of bool, shape (H, W)
        True on the speckles' pixels; never on an unmatched one.

    Examples
    --------
    >>> import numpy as np
    >>> d = np.full((6, 8), 10.0, np.float32)
    >>> d[2, 2] = 20.0                               # an island of one pixel
    >>> d[:, 6:] = np.nan
    >>> mask = speckle_mask(d, max_size_px=4, max_difference_px=1.0)
    >>> int(mask.sum()), bool(mask[2, 2])
    (1, True)
    """
    if not is_whole_number(max_size_px) or max_size_px < 0:
        raise InvalidInputError(f"max_size_px: expected an integer >= 0, got {max_size_px!r}")
    d = _checked(disparity, max_difference_px)
    removed = np.zeros(d.shape, np.bool_)
    if max_size_px > 0 and d.size:
        # a size beyond the pixel count removes every region, as any larger one would
        speckle_kernel(_links(d, max_difference_px), min(int(max_size_px), d.size), removed)
    return removed


def disparity_regions(disparity: np.ndarray, *, max_difference_px: float) -> tuple[np.ndarray, int]:
    """The regions of a disparity map, numbered: matched pixels connected through 4-neighbours
    whose disparities differ by at most ``max_difference_px`` (the regions
    :func:`speckle_mask` measures).

    Parameters
    ----------
    disparity : ndarray of float, shape (H, W)
        Disparity map in pixels, non-finite where unmatched.
    max_difference_px : float
        Neighbours whose disparities differ by at most this, pixels, are in the same region (>= 0).

    Returns
    -------
    labels : ndarray of int32, shape (H, W)
        Region number of each matched pixel, ``0 .. count - 1`` in raster order of the regions'
        first pixels; -1 where unmatched.
    count : int
        Number of regions.

    Examples
    --------
    >>> import numpy as np
    >>> d = np.array([[1.0, 1.5, 9.0], [np.nan, 1.2, 9.5]], np.float32)
    >>> labels, count = disparity_regions(d, max_difference_px=1.0)
    >>> labels.tolist(), count
    ([[0, 0, 1], [-1, 0, 1]], 2)
    """
    d = _checked(disparity, max_difference_px)
    labels = np.empty(d.shape, np.int32)
    count = int(region_kernel(_links(d, max_difference_px), labels)) if d.size else 0
    return labels, count


def _checked(disparity: np.ndarray, max_difference_px: float) -> np.ndarray:
    """``disparity`` as a C-contiguous float32 or float64 map (float16 read as float32), or
    :class:`InvalidInputError` for it or for ``max_difference_px``."""
    if not (is_finite_real(max_difference_px) and max_difference_px >= 0):
        raise InvalidInputError(f"max_difference_px: expected a finite number >= 0, got {max_difference_px!r}")
    d = np.asarray(disparity)
    if d.ndim != 2 or not np.issubdtype(d.dtype, np.floating):
        raise InvalidInputError(f"disparity: expected a 2-D float array, got {d.dtype} {d.shape}")
    return np.ascontiguousarray(d, dtype=np.float64 if d.dtype == np.float64 else np.float32)


def _links(disparity: np.ndarray, max_difference_px: float) -> np.ndarray:
    """``uint8 (H, W)``: the link bytes of :func:`~stereo_obstacles._speckle_kernel.link_kernel`
    for a map checked by :func:`_checked`."""
    links = np.empty(disparity.shape, np.uint8)
    link_kernel(disparity, float(max_difference_px), links)
    return links
