"""A cast shadow keeps the ground's texture: dark, smooth "shadow" is an obstacle.

A shadow changes the light, not the material, so the ground's texture (its reflectance
variations) stays and scales with the brightness: the relative texture ``s / m`` (local
standard deviation over local mean, after the sensor noise is taken out) of ground in shadow
is about that of the lit ground in the reference area. A dark object that the colour rule
reads as shadow (a box of dark, weathered metal on red pavers; the unlit face of a crate)
usually has far less texture than the ground: on the synthetic world 62 % of the missed
obstacle pixels labelled shadow were below 0.3 times the reference's relative texture, 3 % of
the true shadow pixels (docs/segmentation.md, "First look").

:func:`smooth_pixels` and :func:`textureless_shadow` mark the shadow pixels whose relative texture is below
``min_relative_texture`` times the reference area's median, smoothed by a vote and widened
into the shadow (the windows on a smooth face's rim see its edge); phase 1 makes them
obstacles. The sensor noise variance comes from the image itself
(:func:`noise_floor`), so the test needs one image only. Where the reference area's own
texture is not clearly above the noise and the rounding to grey levels (a smooth floor), the
test is not made. Grey images are on the 0..255 scale (:func:`stereo_obstacles.ground_check.grey_levels`).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import cv2
import numpy as np

from stereo_obstacles import quantiles
from stereo_obstacles._shadow_texture_kernel import relative_texture_kernel, sampled_square_means_kernel
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import check_integers, check_numbers
from stereo_obstacles.ground_check import vote

logger = logging.getLogger(__name__)

MIN_NOISE_VARIANCE = 1.0 / 12.0
"""Floor of the noise variance, grey levels squared: the rounding of an image to whole grey
levels adds this much, so a clipped or flat-quantised image (noise floor 0) does not turn the
rounding flicker of the lit ground into texture that a smooth shadow lacks."""

MIN_REFERENCE_TEXTURE_VARIANCE = 1.0
"""The reference area's median texture variance (noise taken out) must also reach this, grey
levels squared (a standard deviation of 1 grey level), for the test to be made."""

NOISE_SAMPLE_STEP = 4
"""The noise floor is taken over the windows centred on every this many rows and columns."""

_NOISE_MASK = np.array([[1, -2, 1], [-2, 4, -2], [1, -2, 1]], dtype=np.float32)
"""Second differences along both axes: flat to any ramp, white noise of variance ``v`` gives
a response of variance ``36 v`` (the sum of the squared coefficients)."""


@dataclass(frozen=True)
class ShadowTextureParameters:
    """Settings of the shadow texture test (defaults measured in docs/segmentation.md).

    Attributes
    ----------
    min_relative_texture
        A shadow pixel whose relative texture is below this times the reference area's
        median is textureless; 0 turns the test off.
    window_px
        Side of the square over which the local mean and standard deviation are taken, and
        over which :func:`noise_floor` averages, pixels (odd).
    vote_window_px, vote_fraction
        A textureless shadow pixel becomes an obstacle only when more than ``vote_fraction``
        of the ``vote_window_px`` square around it is textureless shadow too (an obstacle
        face is a region; a smooth patch of ground is a speck).
    widen_px
        The flagged pixels are then widened by this many pixels into the shadow: the windows
        on the rim of a smooth face saw its edge.
    noise_percentile
        The noise variance taken out of the texture is this percentile, over the image, of
        the local energy of second differences (the flattest windows show the noise alone;
        :func:`noise_floor`).
    min_reference_snr
        The test is made only when the reference area's median texture variance (noise taken
        out) is at least this many times the noise variance (and at least
        :data:`MIN_REFERENCE_TEXTURE_VARIANCE`): on a smooth floor, or ground whose only
        texture is sensor noise, a shadow has nothing to keep.
    """

    min_relative_texture: float = 0.3
    window_px: int = 9
    vote_window_px: int = 15
    vote_fraction: float = 0.5
    widen_px: int = 4
    noise_percentile: float = 5.0
    min_reference_snr: float = 2.0

    def __post_init__(self) -> None:
        check_integers(self, (("window_px", 1, 255), ("vote_window_px", 1, 255)), odd=True)
        check_integers(self, (("widen_px", 0, 64),))
        check_numbers(self, (("min_relative_texture", 0.0, 10.0), ("vote_fraction", 0.0, 0.99),
                             ("noise_percentile", 0.0, 100.0), ("min_reference_snr", 0.0, 1000.0)))


def noise_floor(grey: np.ndarray, *, window_px: int = 9, percentile: float = 5.0) -> float:
    """A low estimate of the sensor noise variance of a grey image, in its units squared.

    The image is filtered with second differences along both axes (blind to constant and
    linear brightness), the squared response averaged over ``window_px`` squares and divided
    by 36 (white noise of variance ``v`` then averages ``v``); the ``percentile`` of that over
    the windows centred on every fourth row and column is the estimate, at least
    :data:`MIN_NOISE_VARIANCE`: the flattest windows hold noise alone. Taking the flattest
    windows makes it low: about 0.6 ``v`` for white noise at the defaults (tested), so the
    texture test subtracts a little less noise than there is. An image without any flat
    window gives more.

    Parameters
    ----------
    grey
        ``float32 (H, W)`` grey image, 0..255 scale.
    window_px, percentile
        Averaging window (odd, pixels) and the percentile taken.
    """
    if isinstance(window_px, bool) or not isinstance(window_px, int) or window_px < 1 or window_px % 2 == 0:
        raise InvalidInputError(f"window_px must be an odd integer >= 1, got {window_px!r}")
    response = cv2.filter2D(grey, cv2.CV_32F, _NOISE_MASK, borderType=cv2.BORDER_REFLECT)
    rows, cols = -(-grey.shape[0] // NOISE_SAMPLE_STEP), -(-grey.shape[1] // NOISE_SAMPLE_STEP)
    energy = np.empty((rows, cols), dtype=np.float64)
    sampled_square_means_kernel(response, window_px, NOISE_SAMPLE_STEP, energy)
    noise = quantiles.percentile(energy.ravel(), percentile) / float(np.sum(_NOISE_MASK ** 2))
    return max(noise, MIN_NOISE_VARIANCE)


def relative_texture(grey: np.ndarray, noise: float, window_px: int) -> tuple[np.ndarray, np.ndarray]:
    """Local texture relative to the local brightness, and the local texture variance.

    Parameters
    ----------
    grey
        ``float32 (H, W)`` grey image.
    noise
        Its noise variance (the image's units squared, e.g. :func:`noise_floor`).
    window_px
        Side of the square windows (odd), pixels; mirrored at the image border.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        ``float32 (H, W)`` relative texture ``sqrt(variance) / max(mean, 1)`` and ``float32
        (H, W)`` texture variance ``max(var - noise, 0)``, with ``mean`` and ``var`` the mean and
        variance over each window.
    """
    size = (window_px, window_px)
    grey = np.ascontiguousarray(grey, dtype=np.float32)
    mean = cv2.blur(grey, size, borderType=cv2.BORDER_REFLECT)
    mean_square = cv2.blur(grey * grey, size, borderType=cv2.BORDER_REFLECT)
    variance, relative = np.empty_like(mean), np.empty_like(mean)
    relative_texture_kernel(mean, mean_square, np.float32(noise), variance, relative)
    return relative, variance


def smooth_pixels(grey: np.ndarray, box: tuple[int, int, int, int], *,
                  params: ShadowTextureParameters = ShadowTextureParameters()) -> np.ndarray | None:
    """``bool (H, W)``: pixels much smoother than the reference area, whatever their label.

    A pixel is smooth when its relative texture (:func:`relative_texture`, noise from
    :func:`noise_floor`) is below ``params.min_relative_texture`` times
    the reference area's median. This is the part of the test that needs no labels, so it can
    run beside the colour classification.

    Parameters
    ----------
    grey
        ``float32 (H, W)`` grey image, 0..255 scale (the mean is floored at 1 grey level).
    box
        Reference area ``(x0, y0, x1, y1)`` in pixels, end exclusive: the lit ground whose
        texture a shadow must keep.
    params
        Thresholds; see :class:`ShadowTextureParameters`.

    Returns
    -------
    numpy.ndarray or None
        None when the test is off or the reference area's texture is not clearly above the
        noise (``params.min_reference_snr``).
    """
    if params.min_relative_texture <= 0.0:
        return None
    noise = noise_floor(grey, window_px=params.window_px, percentile=params.noise_percentile)
    relative, variance = relative_texture(grey, noise, params.window_px)
    x0, y0, x1, y1 = box
    needed = max(params.min_reference_snr * noise, MIN_REFERENCE_TEXTURE_VARIANCE)
    if not quantiles.median(variance[y0:y1, x0:x1].ravel()) >= needed:
        logger.debug("shadow texture test skipped: the reference area's texture variance is below %.3f "
                     "(noise variance %.3f)", needed, noise)
        return None
    reference = quantiles.median(relative[y0:y1, x0:x1].ravel())
    return relative < np.float32(params.min_relative_texture * reference)


def textureless_shadow(smooth: np.ndarray | None, shadow: np.ndarray, *,
                       params: ShadowTextureParameters = ShadowTextureParameters()) -> np.ndarray:
    """``bool (H, W)``: shadow pixels too smooth to be the ground in shadow.

    The smooth shadow pixels, kept where more than ``params.vote_fraction`` of the
    ``params.vote_window_px`` square around them are smooth shadow too, then widened by
    ``params.widen_px`` into the shadow (the windows on the rim of a smooth face saw its edge).

    Parameters
    ----------
    smooth
        ``bool (H, W)`` from :func:`smooth_pixels`, or None (nothing is flagged).
    shadow
        ``bool (H, W)``: the pixels the colour rule calls shadow.
    params
        Vote and window sizes; see :class:`ShadowTextureParameters`.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> grey = rng.normal(120, 12, (80, 120)).astype(np.float32)       # textured ground
    >>> grey[10:40, 10:50] = 0.5 * grey[10:40, 10:50]                  # a cast shadow
    >>> grey[10:40, 70:110] = rng.normal(60, 1, (30, 40))              # a smooth dark box
    >>> shadow = np.zeros(grey.shape, bool)
    >>> shadow[10:40, 10:50] = shadow[10:40, 70:110] = True            # what colour said
    >>> flagged = textureless_shadow(smooth_pixels(grey, (0, 60, 120, 80)), shadow)
    >>> bool(flagged[25, 30]), bool(flagged[25, 90])
    (False, True)
    """
    if smooth is None:
        return np.zeros(shadow.shape, dtype=np.bool_)
    flagged = shadow & smooth
    if params.vote_window_px > 1:
        flagged = vote(flagged, shadow, params.vote_window_px, params.vote_fraction)
    if params.widen_px > 0:
        rim = np.ones((2 * params.widen_px + 1,) * 2, np.uint8)
        flagged = shadow & cv2.dilate(flagged.view(np.uint8), rim).view(np.bool_)
    return flagged


__all__ = ["ShadowTextureParameters", "noise_floor", "relative_texture", "smooth_pixels", "textureless_shadow"]
