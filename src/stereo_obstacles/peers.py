"""Reference stereo matchers to compare ours with: OpenCV StereoBM, StereoSGBM, exhaustive NCC.

Every function takes a rectified pair (RGB ``uint8 (H, W, 3)`` or grey ``uint8 (H, W)``) and
the largest disparity to search, and returns the left disparity as ``float32 (H, W)`` pixels
with NaN where the method gives no value (the project's convention; OpenCV itself returns
fixed-point disparities times 16, with invalid pixels below ``minDisparity``).

Settings are the published ones from the OpenCV samples (``samples/cpp/stereo_match.cpp``):

* **SGBM**: colour input, ``blockSize`` 5, ``P1 = 8*3*5^2``, ``P2 = 32*3*5^2``,
  ``uniquenessRatio`` 10, ``speckleWindowSize`` 100, ``speckleRange`` 2 (px; OpenCV multiplies
  it by 16), ``disp12MaxDiff`` 1, ``preFilterCap`` 63, five-direction mode ``MODE_SGBM``.
* **BM**: grey input, ``blockSize`` 9, ``preFilterCap`` 31, ``textureThreshold`` 10,
  ``uniquenessRatio`` 15, ``speckleWindowSize`` 100, ``speckleRange`` 32 (in 1/16 px, i.e.
  2 px: BM, unlike SGBM, compares the fixed-point values directly), ``disp12MaxDiff`` 1.
* ``numDisparities`` is the largest disparity plus one, rounded up to a multiple of 16.
* **NCC-WTA** (the paper's "traditional" matcher): for every left pixel, the disparity in
  ``0..max_disparity`` with the highest normalised cross-correlation of 5x5 grey windows,
  refined by a parabola through the neighbouring scores. No consistency check, so it is
  dense wherever the windows have texture.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from stereo_obstacles._exhaustive_ncc_kernel import _ncc_wta_kernel
from stereo_obstacles.errors import ImageMismatchError, InvalidInputError
from stereo_obstacles.image_pairs import check_same_size

OPENCV_DISPARITY_SCALE = 16
"""OpenCV block matchers return ``round(d * 16)`` as ``int16``."""


def num_disparities_for(max_disparity: float) -> int:
    """OpenCV ``numDisparities`` covering ``0..max_disparity``: a multiple of 16.

    Examples
    --------
    >>> num_disparities_for(14.0), num_disparities_for(19.75), num_disparities_for(55.0)
    (16, 32, 64)
    """
    _check_max_disparity(max_disparity)
    needed = math.ceil(max_disparity) + 1
    return OPENCV_DISPARITY_SCALE * math.ceil(needed / OPENCV_DISPARITY_SCALE)


def sgbm_disparity(left: np.ndarray, right: np.ndarray, *, max_disparity: float,
                   block_size: int = 5) -> np.ndarray:
    """OpenCV semi-global block matching (``cv2.StereoSGBM``) with the published settings.

    Parameters
    ----------
    left, right : numpy.ndarray
        Rectified images, ``uint8`` RGB ``(H, W, 3)`` or grey ``(H, W)``, the same shape.
    max_disparity : float
        Largest disparity to search, pixels (> 0).
    block_size : int
        Odd matching block size in pixels.

    Returns
    -------
    numpy.ndarray
        ``float32 (H, W)`` disparity in pixels (1/16 px steps), NaN where invalid.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> right = rng.integers(0, 256, (40, 80, 3), dtype=np.uint8)
    >>> left = np.roll(right, 6, axis=1)
    >>> d = sgbm_disparity(left, right, max_disparity=10)
    >>> float(np.nanmedian(d))
    6.0
    """
    left, right = _check_pair(left, right)
    _check_block_size(block_size)
    channels = 1 if left.ndim == 2 else 3
    matcher = cv2.StereoSGBM_create(
        minDisparity=0,
        numDisparities=num_disparities_for(max_disparity),
        blockSize=block_size,
        P1=8 * channels * block_size ** 2,
        P2=32 * channels * block_size ** 2,
        disp12MaxDiff=1,
        preFilterCap=63,
        uniquenessRatio=10,
        speckleWindowSize=100,
        speckleRange=2,
        mode=cv2.STEREO_SGBM_MODE_SGBM,
    )
    return _from_opencv(matcher.compute(left, right), min_disparity=0)


def bm_disparity(left: np.ndarray, right: np.ndarray, *, max_disparity: float,
                 block_size: int = 9) -> np.ndarray:
    """OpenCV block matching (``cv2.StereoBM``) on grey images with the published settings.

    Parameters and result as :func:`sgbm_disparity`; colour input is converted to grey
    (ITU-R BT.601 weights). ``block_size`` must be odd and in ``5..255``.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> right = rng.integers(0, 256, (40, 80), dtype=np.uint8)
    >>> left = np.roll(right, 6, axis=1)
    >>> float(np.nanmedian(bm_disparity(left, right, max_disparity=10)))
    6.0
    """
    left, right = _check_pair(left, right)
    _check_block_size(block_size)
    if block_size < 5:
        raise InvalidInputError(f"block_size must be >= 5 for StereoBM, got {block_size}")
    matcher = cv2.StereoBM_create(numDisparities=num_disparities_for(max_disparity),
                                  blockSize=block_size)
    matcher.setPreFilterCap(31)
    matcher.setTextureThreshold(10)
    matcher.setUniquenessRatio(15)
    matcher.setSpeckleWindowSize(100)
    matcher.setSpeckleRange(32)
    matcher.setDisp12MaxDiff(1)
    matcher.setMinDisparity(0)
    return _from_opencv(matcher.compute(_grey(left), _grey(right)), min_disparity=0)


def ncc_wta_disparity(left: np.ndarray, right: np.ndarray, *, max_disparity: float,
                      radius: int = 2, min_std: float = 0.5) -> np.ndarray:
    """Exhaustive winner-takes-all matching with NCC on ``(2 radius + 1)^2`` grey windows.

    Every disparity ``0..ceil(max_disparity)`` is tried for every left pixel whose window
    lies inside both images; the best NCC wins and is refined to subpixel by a parabola
    through its two neighbours' scores.

    Parameters
    ----------
    left, right : numpy.ndarray
        Rectified images, ``uint8`` RGB ``(H, W, 3)`` or grey ``(H, W)``, the same shape.
    max_disparity : float
        Largest disparity to search, pixels (> 0).
    radius : int
        Window radius in pixels (2 gives the paper's 5x5 window).
    min_std : float
        Windows whose grey-level standard deviation is below this (textureless, where NCC
        is undefined) are not matched.

    Returns
    -------
    numpy.ndarray
        ``float32 (H, W)`` disparity in pixels, NaN at the image border, where
        ``x < d + radius`` for every candidate, and on textureless windows.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> right = rng.integers(0, 256, (20, 40), dtype=np.uint8)
    >>> left = np.roll(right, 4, axis=1)
    >>> float(np.nanmedian(ncc_wta_disparity(left, right, max_disparity=8)))
    4.0
    """
    left, right = _check_pair(left, right)
    _check_max_disparity(max_disparity)
    if not isinstance(radius, int) or isinstance(radius, bool) or radius < 1:
        raise InvalidInputError(f"radius must be a positive integer, got {radius!r}")
    if not math.isfinite(min_std) or min_std < 0:
        raise InvalidInputError(f"min_std must be >= 0, got {min_std}")
    grey_l = _grey(left).astype(np.float64)
    grey_r = _grey(right).astype(np.float64)
    h, w = grey_l.shape
    if h < 2 * radius + 1 or w < 2 * radius + 1:
        raise InvalidInputError(f"images of {w}x{h} are smaller than the "
                                f"{2 * radius + 1}x{2 * radius + 1} window")
    mean_l, std_l = _window_mean_std(grey_l, radius)
    mean_r, std_r = _window_mean_std(grey_r, radius)
    d_max = min(math.ceil(max_disparity), w - 1)
    disparity, _ = _ncc_wta_kernel(grey_l, grey_r, mean_l, std_l, mean_r, std_r,
                                   radius, 0, d_max, float(min_std))
    return disparity


def _window_mean_std(image: np.ndarray, radius: int) -> tuple[np.ndarray, np.ndarray]:
    """Mean and standard deviation of the square window around each pixel (float64)."""
    size = (2 * radius + 1, 2 * radius + 1)
    mean = cv2.boxFilter(image, cv2.CV_64F, size, normalize=True, borderType=cv2.BORDER_REFLECT)
    mean_sq = cv2.boxFilter(image * image, cv2.CV_64F, size, normalize=True,
                            borderType=cv2.BORDER_REFLECT)
    std = np.sqrt(np.maximum(mean_sq - mean * mean, 0.0))
    return np.ascontiguousarray(mean), np.ascontiguousarray(std)


def _from_opencv(raw: np.ndarray, *, min_disparity: int) -> np.ndarray:
    """OpenCV fixed-point ``int16`` disparity (x16) to float32 pixels with NaN for invalid."""
    disparity = raw.astype(np.float32) / OPENCV_DISPARITY_SCALE
    disparity[raw < min_disparity * OPENCV_DISPARITY_SCALE] = np.nan
    return disparity


def _grey(image: np.ndarray) -> np.ndarray:
    return image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)


def _check_pair(left: np.ndarray, right: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    left = np.asarray(left)
    right = np.asarray(right)
    for name, image in (("left", left), ("right", right)):
        if image.dtype != np.uint8:
            raise InvalidInputError(f"{name} image must be uint8, got {image.dtype}")
        if not (image.ndim == 2 or (image.ndim == 3 and image.shape[2] == 3)):
            raise InvalidInputError(f"{name} image must be (H, W) or (H, W, 3), "
                                    f"got shape {image.shape}")
    check_same_size(left, right)
    if left.ndim != right.ndim:
        raise ImageMismatchError(f"left image is {left.shape} but right image is {right.shape}")
    return np.ascontiguousarray(left), np.ascontiguousarray(right)


def _check_max_disparity(max_disparity: float) -> None:
    if (not isinstance(max_disparity, (int, float, np.integer, np.floating))
            or isinstance(max_disparity, bool) or not math.isfinite(max_disparity)
            or max_disparity <= 0):
        raise InvalidInputError(f"max_disparity must be a finite number > 0, got {max_disparity!r}")


def _check_block_size(block_size: int) -> None:
    if not isinstance(block_size, int) or isinstance(block_size, bool) or block_size < 1 \
            or block_size % 2 == 0:
        raise InvalidInputError(f"block_size must be an odd positive integer, got {block_size!r}")


__all__ = ["OPENCV_DISPARITY_SCALE", "bm_disparity", "ncc_wta_disparity", "num_disparities_for",
           "sgbm_disparity"]
