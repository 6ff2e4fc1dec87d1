"""The paper's 7x7 median filter on hue, done right for an angle with missing values.

Hue is an angle and many pixels have none (grey or dark pixels), so a median of raw hue values
is wrong twice: across the 0/360 wrap (the median of 350 and 10 degrees is not 180) and where
invalid pixels would enter the window as zeros. The segmentation only ever asks one question
of the filtered hue: *is it within ``T`` degrees of the reference hue?* We therefore filter
the quantity that question is about, the circular distance ``|dH|`` to the reference, which
lies in ``[0, 180]`` with no wrap, and take its median over the **valid** pixels of the window
only. For a threshold ``T`` the (lower) median of the valid distances is ``<= T`` exactly when
at least half of the window's valid pixels are within ``T``::

    median(|dH|) <= T   <=>   2 * #(valid and |dH| <= T)  >=  #valid

so the filter-then-threshold is computed exactly with two box sums (O(1) per pixel, about
1 ms on 640x480) instead of a sort of 49 values per pixel. A window without any valid hue
has no median: the result marks it as such and the caller decides (grey-ground rules).

Filtering ``|dH|`` rather than the hue itself also avoids the other classic mistake: a median
of hues rotated to the reference frame can land on the reference when the window holds
obstacle hues on both sides of it; the median distance cannot.
"""

from __future__ import annotations

import cv2
import numpy as np

from stereo_obstacles.colour import hue_difference
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import is_whole_number

DEFAULT_FILTER_SIZE = 7
"""The paper's median window: 7 x 7 pixels."""


def _check_size(size: int) -> int:
    if not is_whole_number(size) or size < 1 or size % 2 == 0:
        raise InvalidInputError(f"size must be an odd positive integer, got {size!r}")
    return int(size)


def window_counts(flags: np.ndarray, *, size: int = DEFAULT_FILTER_SIZE) -> np.ndarray:
    """Per pixel, how many pixels of the ``size x size`` window centred on it are set.

    Parameters
    ----------
    flags
        ``uint8 (H, W)`` or ``(H, W, C)`` with values 0 or 1 (C up to 4).
    size
        Odd window side in pixels. Pixels outside the image count as unset.

    Returns
    -------
    numpy.ndarray
        ``uint16``, same shape as ``flags``.
    """
    size = _check_size(size)
    f = np.asarray(flags)
    if f.dtype != np.uint8 or f.ndim not in (2, 3):
        raise InvalidInputError(f"flags must be uint8 (H, W) or (H, W, C), got {f.dtype} {f.shape}")
    counts = cv2.boxFilter(f, cv2.CV_16U, (size, size), normalize=False,
                           borderType=cv2.BORDER_CONSTANT)
    return counts.reshape(f.shape)


def median_within(close: np.ndarray, valid: np.ndarray, *,
                  size: int = DEFAULT_FILTER_SIZE) -> tuple[np.ndarray, np.ndarray]:
    """Threshold of a masked median filter, from the per-pixel threshold test.

    With ``close = valid & (value <= T)``, returns whether the lower median of the valid
    values in each ``size x size`` window is ``<= T``, and whether the window has any valid
    value at all.

    Parameters
    ----------
    close, valid
        ``bool (H, W)``; ``close`` must imply ``valid``.
    size
        Odd window side in pixels.

    Returns
    -------
    within : numpy.ndarray
        ``bool (H, W)``, False where the window has no valid value.
    has_value : numpy.ndarray
        ``bool (H, W)``.
    """
    c = np.asarray(close)
    v = np.asarray(valid)
    if c.dtype != bool or v.dtype != bool or c.ndim != 2 or c.shape != v.shape:
        raise InvalidInputError(f"close and valid must be bool (H, W) of one shape, got "
                                f"{c.dtype} {c.shape} and {v.dtype} {v.shape}")
    if np.any(c & ~v):
        raise InvalidInputError("close must imply valid (a pixel without a value cannot be close)")
    counts = window_counts(np.dstack([c, v]).view(np.uint8), size=size)
    n_close = counts[..., 0].astype(np.int32)
    n_valid = counts[..., 1].astype(np.int32)
    has_value = n_valid > 0
    return has_value & (2 * n_close >= n_valid), has_value


def median_hue_within(hue_deg: np.ndarray, reference_hue_deg: float, threshold_deg: float, *,
                      size: int = DEFAULT_FILTER_SIZE) -> tuple[np.ndarray, np.ndarray]:
    """Whether the 7x7 median circular hue distance to a reference is within a threshold.

    Parameters
    ----------
    hue_deg
        ``float (H, W)`` hue in degrees, NaN where invalid (as :func:`~stereo_obstacles.colour.rgb_to_hsi`).
    reference_hue_deg
        The reference hue in degrees (any value; it is wrapped).
    threshold_deg
        Hue threshold ``T`` in degrees, ``0 <= T <= 180``.
    size
        Odd window side in pixels (the paper's 7).

    Returns
    -------
    within : numpy.ndarray
        ``bool (H, W)``: median of ``|dH|`` over the window's valid pixels ``<= T``.
    has_hue : numpy.ndarray
        ``bool (H, W)``: the window holds at least one valid hue.

    Examples
    --------
    >>> import numpy as np
    >>> hue = np.full((9, 9), 355.0, dtype=np.float32)
    >>> hue[:, 5:] = 8.0          # across the wrap: 13 degrees from 355
    >>> within, _ = median_hue_within(hue, 0.0, 10.0)
    >>> bool(within.all())
    True
    """
    h = np.asarray(hue_deg)
    if h.ndim != 2 or not np.issubdtype(h.dtype, np.floating):
        raise InvalidInputError(f"hue_deg must be a float (H, W) array, got {h.dtype} {h.shape}")
    if not (np.isfinite(reference_hue_deg) and np.isfinite(threshold_deg)
            and 0.0 <= threshold_deg <= 180.0):
        raise InvalidInputError(f"need a finite reference hue and 0 <= threshold_deg <= 180, got "
                                f"{reference_hue_deg!r} and {threshold_deg!r}")
    valid = np.isfinite(h)
    with np.errstate(invalid="ignore"):
        close = valid & (np.abs(hue_difference(h, reference_hue_deg)) <= threshold_deg)
    return median_within(close, valid, size=size)


__all__ = ["DEFAULT_FILTER_SIZE", "window_counts", "median_within", "median_hue_within"]
