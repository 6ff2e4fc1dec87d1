"""How uncertain each match's disparity is, from the pair's noise and the texture of its window.

Matching a window whose texture is weak against the image noise gives a disparity that can be
off by a pixel or more; on far ground such errors come in patches (neighbouring windows share
most of their pixels) and a patch one pixel too near stands above the ground plane like an
obstacle. Over the 30 evaluation scenes (rendered with 3 x 3 rays per pixel), sensor noise of
2 grey levels gave 34 such false alarms and JPEG compression at quality 90 gave 42
(``docs/pipeline.md``, "Noise and compression").

The standard error model of window matching (e.g. Matthies and Shafer, "Error modeling in
stereo navigation", 1987) gives the standard deviation of the disparity of a window as

    sigma_d = sqrt(2) * sigma / sqrt(sum over the window of g_x ** 2)

for image noise ``sigma`` (grey levels, in each image) and the horizontal intensity gradient
``g_x`` of the noise-free image (grey levels per pixel). Here ``sigma`` is measured on the pair
itself, from the photometric residual of the matches (which also captures compression
artefacts that a noise estimate on one image misses), and the noise's own share of the measured
gradient energy is subtracted. The model assumes white noise: for JPEG's spatially correlated
errors it is an approximation, and for well-textured windows the matcher's own floor (about
0.1 px: subpixel fit, pixel locking) exceeds it, which the pipeline's fixed 0.5 px floor covers.
"""

from __future__ import annotations

import cv2
import numpy as np

from stereo_obstacles._disparity_uncertainty_kernel import match_samples_kernel
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.quantiles import MAD_TO_SIGMA
from stereo_obstacles.similarity import RADIUS

RESIDUAL_ROW_STEP = 8
"""The matched pixels of every this-many-th row enter the noise estimate."""

OUTLIER_DEVIATIONS = 3.0
"""Residuals beyond this many robust deviations are left out of the refitted gain and offset."""


def pair_noise_sigma(left_grey: np.ndarray, right_grey: np.ndarray, disparity: np.ndarray) -> float:
    """Noise of one image of the pair, grey levels, from the residual of the matches.

    The right image is interpolated linearly at each match's subpixel position ``x - d``; a gain
    and an offset between the cameras (which the normalised cross-correlation of the matcher
    ignores) are fitted by least squares, ``left = g right(x - d) + o``, and refitted once
    without the residuals beyond three robust deviations. What remains of a correct match is the
    left image's noise plus ``g`` times the interpolated right noise, whose variance is
    ``1 + g**2 ((1 - f)**2 + f**2)`` times one image's for the position's fraction ``f``; each
    residual is divided by the root of that, and the robust deviation (1.4826 MAD) of the
    results is the estimate. Wrong matches are a minority and move the median little (a tenth
    of the matches wrong raises the estimate by about 13 %). Returns 0.0 when fewer than 3
    matches can be sampled.

    Parameters
    ----------
    left_grey, right_grey
        ``float32 (H, W)`` grey images.
    disparity
        ``float (H, W)`` left disparity in pixels, NaN where unmatched.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> scene = rng.uniform(0, 255, (400, 90)).astype(np.float32)
    >>> left = scene[:, 10:80] + rng.normal(0, 2, (400, 70)).astype(np.float32)
    >>> right = 1.2 * scene[:, 14:84] + rng.normal(0, 2, (400, 70)).astype(np.float32)  # 20 % more gain
    >>> d = np.full((400, 70), 4.0, np.float32); d[:, :4] = np.nan
    >>> round(pair_noise_sigma(left, right, d), 1)
    2.0
    """
    left_grey, right_grey, disparity = (np.asarray(a) for a in (left_grey, right_grey, disparity))
    if not left_grey.shape == right_grey.shape == disparity.shape or left_grey.ndim != 2:
        raise InvalidInputError(f"left {left_grey.shape}, right {right_grey.shape} and disparity "
                                f"{disparity.shape} must be one 2-D shape")
    lefts, warped, kept = match_samples_kernel(np.ascontiguousarray(left_grey, np.float32),
                                               np.ascontiguousarray(right_grey, np.float32),
                                               np.ascontiguousarray(disparity, np.float32), RESIDUAL_ROW_STEP)
    if lefts.size < 3:
        return 0.0
    use = np.ones(lefts.size, dtype=bool)
    for _ in range(2):  # fit, then refit without the outliers of the first fit
        gain, offset = _line_fit(warped[use], lefts[use])
        residual = (lefts - gain * warped - offset) / np.sqrt(1.0 + gain * gain * kept)
        centre = np.median(residual)
        spread = MAD_TO_SIGMA * np.median(np.abs(residual - centre))
        use = np.abs(residual - centre) <= OUTLIER_DEVIATIONS * spread
        if use.sum() < 3:
            break
    return float(spread)


def _line_fit(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """Least-squares ``y = g x + o``; ``(1, mean(y - x))`` when ``x`` does not vary."""
    x_mean, y_mean = float(x.mean()), float(y.mean())
    variance = float(np.mean((x - x_mean) ** 2))
    if variance <= 1e-12:
        return 1.0, y_mean - x_mean
    gain = float(np.mean((x - x_mean) * (y - y_mean))) / variance
    return gain, y_mean - gain * x_mean


def disparity_sigma_px(left_grey: np.ndarray, noise_sigma: float, *, max_sigma_px: float) -> np.ndarray:
    """``float32 (H, W)``: standard deviation of each pixel's disparity, pixels, at most ``max_sigma_px``.

    Parameters
    ----------
    left_grey
        ``float32 (H, W)`` grey left image.
    noise_sigma
        Image noise in grey levels (:func:`pair_noise_sigma`), >= 0.
    max_sigma_px
        Upper bound of the result (> 0): a window with no texture left after the noise's share
        is removed would otherwise be infinitely uncertain.

    Examples
    --------
    >>> import numpy as np
    >>> ramp = np.tile(np.arange(40, dtype=np.float32) * 4.0, (20, 1))   # 4 grey levels per pixel
    >>> sigma = disparity_sigma_px(ramp, 2.0, max_sigma_px=1.0)
    >>> round(float(sigma[10, 20]), 3)                                    # sqrt(2) 2 / sqrt(25 (16 - 2))
    0.151
    >>> float(disparity_sigma_px(np.zeros((20, 40), np.float32), 2.0, max_sigma_px=1.0)[10, 20])
    1.0
    """
    if not (np.isfinite(noise_sigma) and noise_sigma >= 0):
        raise InvalidInputError(f"noise_sigma must be a number >= 0 grey levels, got {noise_sigma}")
    if not (np.isfinite(max_sigma_px) and max_sigma_px > 0):
        raise InvalidInputError(f"max_sigma_px must be a number > 0 pixels, got {max_sigma_px}")
    grey = np.asarray(left_grey, dtype=np.float32)
    if grey.ndim != 2:
        raise InvalidInputError(f"left_grey must be 2-D, got shape {grey.shape}")
    side = 2 * RADIUS + 1
    gradient = cv2.Sobel(grey, cv2.CV_32F, 1, 0, ksize=1, scale=0.5, borderType=cv2.BORDER_REPLICATE)
    energy = cv2.boxFilter(cv2.multiply(gradient, gradient), -1, (side, side), normalize=False,
                           borderType=cv2.BORDER_REPLICATE)
    # a central difference carries half of the noise variance: sigma**2 / 2 per pixel of the window
    signal = np.maximum(energy - np.float32(side * side * noise_sigma * noise_sigma / 2.0), np.float32(1e-12))
    return np.minimum(np.float32(np.sqrt(2.0) * noise_sigma) / np.sqrt(signal), np.float32(max_sigma_px))
