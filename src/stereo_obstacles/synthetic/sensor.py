"""From scene radiance to 8-bit pixels: lens blur, exposure, gain, sRGB-like gamma, noise, JPEG.

A camera integrates linear radiance over each pixel (the renderer averages its sub-pixel
samples) after the lens has blurred it slightly (a Gaussian point spread), multiplies by exposure and gain, clips at saturation, applies a display gamma of
1/2.2, adds an offset and Gaussian read noise in grey levels, and rounds to 8 bits. Many
cameras (webcams in MJPG mode) then deliver the frame JPEG-compressed (:func:`compress_jpeg`).
"""

from __future__ import annotations

import cv2
import numpy as np

GAMMA = 2.2
"""Display gamma: stored value = (linear exposure) ** (1 / GAMMA)."""


def develop(radiance: np.ndarray, *, blur_sigma_px: float, exposure: float, gain: float,
            bias_levels: float, noise_sigma: float, rng: np.random.Generator) -> np.ndarray:
    """Turn linear radiance ``(H, W, 3)`` into an RGB ``uint8`` image.

    Parameters
    ----------
    radiance : numpy.ndarray
        Linear scene radiance per pixel, ``(H, W, 3)``.
    blur_sigma_px : float
        Standard deviation of the lens blur in pixels (0 = none).
    exposure, gain : float
        Multipliers of the linear signal (gain differs between the two cameras).
    bias_levels : float
        Brightness offset added after the gamma, in grey levels.
    noise_sigma : float
        Standard deviation of the additive Gaussian noise, grey levels (0 = none).
    rng : numpy.random.Generator
        Source of the noise.
    """
    if blur_sigma_px > 0:
        radiance = cv2.GaussianBlur(radiance, (0, 0), blur_sigma_px, borderType=cv2.BORDER_REFLECT)
    linear = np.clip(radiance * (exposure * gain), 0.0, 1.0)
    levels = 255.0 * linear ** (1.0 / GAMMA) + bias_levels
    if noise_sigma > 0:
        levels = levels + rng.normal(0.0, noise_sigma, size=levels.shape)
    return np.clip(np.rint(levels), 0, 255).astype(np.uint8)


def compress_jpeg(image: np.ndarray, quality: int) -> np.ndarray:
    """``image`` (RGB ``uint8 (H, W, 3)``) after a JPEG round trip at ``quality`` (1..100, OpenCV's
    encoder: 4:2:0 chroma subsampling, 8 x 8 blocks)."""
    ok, encoded = cv2.imencode(".jpg", np.ascontiguousarray(image[..., ::-1]), [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:
        raise RuntimeError("OpenCV could not encode a JPEG")  # pragma: no cover - a broken OpenCV build
    return np.ascontiguousarray(cv2.imdecode(encoded, cv2.IMREAD_COLOR)[..., ::-1])
