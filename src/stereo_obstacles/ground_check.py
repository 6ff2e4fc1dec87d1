"""Phase 1's stereo cue: pixels that the right image does not see on the ground plane.

Colour alone cannot tell an obstacle from the ground when it has the ground's colour (a box of
darkened pavers, a grey post on grey asphalt) or looks like the ground in shadow. Geometry can:
for a rectified pair, every ground pixel ``(x, y)`` of the left image appears in the right image
at ``x - d(x, y)``, with ``d = a x + b y + c`` the ground plane in disparity space. A pixel
that stands up from the ground (an obstacle) has a larger disparity, so the right image read
through the plane shows something else there. This module

1. estimates the plane from the reference area alone (the rectangle phase 1 already assumes to
   be ground): small patches of the left image are found along their row in the right image
   (normalised cross-correlation, parabola subpixel) and a plane is fitted robustly to the
   patch disparities (:func:`stereo_obstacles.ground_plane.fit_plane_points`);
2. reads the right image through the plane and compares it with the left over the valid
   pixels of a ``window_px`` square (where the plane maps into the right image; at least
   :data:`MIN_VALID_SHARE` of the square): the variance of the difference ``D`` (zero mean,
   so an offset between the cameras does not count, and a gain only through the texture it
   scales), against the ground's own level ``D_ref`` (the median over the reference area:
   sensor noise) and against what small misalignments would explain on strong edges, ``E`` =
   the window mean of ``dx^2 gx^2 + dy^2 gy^2`` with ``gx``, ``gy`` the image gradient,
   ``dx = misalignment_px`` (an error of the plane) and ``dy = row_misalignment_px`` (real
   pairs are rectified to a fraction of a pixel, and lane markings have strong edges): a
   pixel is **off the ground** when ``D > mismatch_factor * D_ref + E``;
3. smooths that mask by a vote (:func:`vote`): off where more than ``vote_fraction`` of the
   ``vote_window_px`` square around the pixel is;
4. marks the pixels above the plane's horizon (:func:`above_horizon`), where no ground can be
   seen.

When the reference area gives no plane, step 1 is tried once more on a taller band
(``fallback_band_factor``).

Textureless surfaces give no evidence either way (``D`` stays at the noise level), so the
check only ever adds obstacles to the colour labels; it never turns a colour obstacle into
ground. Known false alarms (measured in docs/segmentation.md): ground just left of an obstacle
that the right camera cannot see (its width is the obstacle's disparity minus the ground's),
and a rim of about ``window_px / 2`` around obstacles.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field, replace

import cv2
import numpy as np

from stereo_obstacles._ground_check_kernel import (PATCH_AT_BORDER, PATCH_FLAT, PATCH_FOUND, PATCH_WEAK, TERMS,
                                                   ground_warp_terms_kernel, off_ground_kernel,
                                                   patch_disparities_kernel, window_variance_kernel)
from stereo_obstacles.colour import check_rgb
from stereo_obstacles.errors import ImageMismatchError, InvalidInputError
from stereo_obstacles.field_checks import check_integers, check_numbers, plain_numbers
from stereo_obstacles.ground_plane import GroundPlane, PlaneFitParameters, fit_plane_points
from stereo_obstacles.quantiles import median

logger = logging.getLogger(__name__)

MIN_VALID_SHARE = 0.5
"""A window is judged on its valid pixels (where the plane maps into the right image), and only
when they are at least this share of it (near the left border and the horizon)."""

MIN_NOISE_VARIANCE = 0.25
"""Floor of the ground's difference variance ``D_ref`` (grey levels squared, 0..255 scale): a
noise-free pair would otherwise call every rounding difference an obstacle."""


@dataclass(frozen=True)
class GroundCheckParameters:
    """Settings of the stereo ground check (defaults measured in docs/segmentation.md).

    Attributes
    ----------
    window_px
        Side of the square over which left and warped right are compared, pixels (odd, >= 3).
    mismatch_factor
        Off the ground when the difference variance exceeds this many times the ground's own
        (the reference area's median).
    misalignment_px
        Disparity error of the plane tolerated on strong edges, pixels: adds
        ``misalignment_px^2`` times the window's mean squared horizontal gradient.
    row_misalignment_px
        Rectification error across the rows tolerated on strong edges, pixels: adds its square
        times the window's mean squared vertical gradient.
    vote_window_px, vote_fraction
        The off-ground pixels are then smoothed by a vote: a pixel is off the ground when more
        than ``vote_fraction`` of the ``vote_window_px`` square around it is (fills the
        speckle on weakly textured obstacles, drops isolated specks). 1 turns the vote off.
    patch_rows_px, patch_cols_px
        Size of the reference-area patches matched to estimate the plane, pixels (odd).
    patch_grid
        ``(rows, columns)``: that many patches, evenly spread over the reference area.
    min_patch_std
        Patches flatter than this (grey levels, 0..255 scale) are not matched.
    min_patch_correlation
        A patch's disparity is kept when its correlation peak reaches this.
    max_disparity_fraction
        The patch search covers disparities up to this fraction of the image width.
    min_inlier_fraction
        The plane must agree (within ``plane_fit.inlier_threshold_px``) with at least this
        fraction of the patch disparities; otherwise the reference area is not one plane
        (obstacles, a slope, a poor match) and the check is not made.
    plane_fit
        RANSAC settings of the plane fit to the patch disparities. Its ``min_slope_y`` is 0.03
        px of disparity per row here, not 0.01: the reference area spans few rows, and over
        60 rows a wall's noisy disparities can pass for a slope of 0.01; a ground seen by a
        rig of baseline ``B`` at height ``h`` has ``B / h`` (0.075 for 6 cm at 0.8 m, 0.33 on
        KITTI).
    fallback_band_factor
        When the reference area gives no plane (an obstacle covers part of it and the rest of
        the ground has too little texture), the plane is estimated once more from a band this
        many times as tall (cut at the image's top), with the same bottom edge and as many more
        rows of patches as the band has more rows, rounded (the plane fit is robust to what
        stands in it; ground further up, shadow edges and the feet of obstacles add texture).
        The ground's own difference level is then measured over that band too: the obstacle
        that made the reference area fail would raise it. 1 turns the retry off.
    horizon_margin_px
        Pixels where the plane's disparity is below ``-horizon_margin_px`` lie above the
        ground's horizon, where no ground can be seen (:func:`above_horizon`); phase 1 calls
        none of them ground. The margin covers the plane's error near the horizon. None turns
        the rule off.
    """

    window_px: int = 9
    mismatch_factor: float = 1.5
    misalignment_px: float = 0.75
    row_misalignment_px: float = 0.5
    vote_window_px: int = 15
    vote_fraction: float = 0.4
    patch_rows_px: int = 9
    patch_cols_px: int = 33
    patch_grid: tuple[int, int] = (3, 13)
    min_patch_std: float = 2.0
    min_patch_correlation: float = 0.7
    max_disparity_fraction: float = 0.25
    min_inlier_fraction: float = 0.5
    fallback_band_factor: float = 2.0
    horizon_margin_px: float | None = 0.5
    plane_fit: PlaneFitParameters = field(
        default_factory=lambda: PlaneFitParameters(inlier_threshold_px=0.5, min_inliers=10, min_slope_y=0.03))

    def __post_init__(self) -> None:
        plain_numbers(self)                      # NumPy scalars as Python numbers (JSON-ready)
        check_integers(self, (("window_px", 3, 255), ("vote_window_px", 1, 255), ("patch_rows_px", 3, 255),
                              ("patch_cols_px", 3, 255)), odd=True)
        grid = self.patch_grid
        if (not isinstance(grid, tuple) or len(grid) != 2
                or any(isinstance(n, bool) or not isinstance(n, int) or n < 1 for n in grid)):
            raise InvalidInputError(f"patch_grid must be a tuple of two integers >= 1, got {grid!r}")
        check_numbers(self, (("mismatch_factor", 1.0, 100.0), ("misalignment_px", 0.0, 10.0),
                             ("row_misalignment_px", 0.0, 10.0), ("vote_fraction", 0.0, 0.99),
                             ("min_patch_std", 0.0, 255.0), ("min_patch_correlation", 0.0, 1.0),
                             ("max_disparity_fraction", 0.01, 1.0), ("min_inlier_fraction", 0.0, 1.0),
                             ("fallback_band_factor", 1.0, 100.0)))
        if self.horizon_margin_px is not None:
            check_numbers(self, (("horizon_margin_px", 0.0, 1000.0),))
        if not isinstance(self.plane_fit, PlaneFitParameters):
            raise InvalidInputError(f"plane_fit must be PlaneFitParameters, got {type(self.plane_fit).__name__}")


@dataclass(frozen=True, eq=False)
class GroundCheck:
    """Result of :func:`check_ground`.

    Attributes
    ----------
    plane
        The ground plane in disparity space estimated from the reference area.
    off_ground
        ``bool (H, W)``: pixels the right image does not see on that plane.
    noise_variance
        ``D_ref``, the ground's difference variance (grey levels squared, 0..255 scale).
    n_patches
        Patches whose disparity entered the plane fit.
    plane_box
        ``(x0, y0, x1, y1)`` the plane was estimated from: the reference area, or the taller band
        of ``fallback_band_factor`` when the reference area gave no plane.
    fallback_reason
        Why the reference area gave no plane when the taller band was used (None otherwise).
        Not logged here: the caller decides (phase 1 logs it as a warning once its colour
        work has succeeded).
    above_horizon
        ``bool (H, W)``: the pixels above the plane's horizon by more than ``horizon_margin_px``
        (:func:`above_horizon`; none when the margin is None).
    """

    plane: GroundPlane
    off_ground: np.ndarray
    noise_variance: float
    n_patches: int
    plane_box: tuple[int, int, int, int]
    fallback_reason: str | None
    above_horizon: np.ndarray


def grey_levels(rgb: np.ndarray) -> np.ndarray:
    """``float32 (H, W)`` luma of an ``uint8`` or ``uint16`` RGB image on the 0..255 scale.

    Unlike :func:`stereo_obstacles.similarity.to_grey` (any dtype, own units), ``uint16`` is
    rescaled: the thresholds here (``min_patch_std``, :data:`MIN_NOISE_VARIANCE`) are in 8-bit
    grey levels."""
    grey = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY).astype(np.float32)
    if rgb.dtype == np.uint16:
        grey *= np.float32(255.0 / 65535.0)
    return grey


def _spread(first: int, last: int, n: int) -> list[int]:
    """Up to ``n`` distinct integers evenly spread over ``[first, last]`` (none when empty)."""
    if last < first:
        return []
    return sorted({int(round(v)) for v in np.linspace(first, last, n)})


def _check_box(box: tuple[int, int, int, int], shape: tuple[int, ...]) -> None:
    """Raise :class:`InvalidInputError` unless ``box`` ``(x0, y0, x1, y1)`` is a non-empty
    rectangle inside an image of ``shape`` ``(H, W, ...)``."""
    h, w = shape[:2]
    if not (isinstance(box, (tuple, list)) and len(box) == 4
            and all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) for v in box)):
        raise InvalidInputError(f"reference area must be four integers (x0, y0, x1, y1), got {box!r}")
    x0, y0, x1, y1 = box
    if not (0 <= x0 < x1 <= w and 0 <= y0 < y1 <= h):
        raise InvalidInputError(f"reference area {box} is not a non-empty rectangle inside the {w}x{h} image")


def _check_grey_pair(left: np.ndarray, right: np.ndarray, box: tuple[int, int, int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Both grey images as C-contiguous ``float32 (H, W)`` arrays of one shape, ``box`` inside them
    (the compiled kernels read without bounds checks); raises :class:`InvalidInputError`."""
    left, right = np.asarray(left), np.asarray(right)
    if left.ndim != 2 or left.shape != right.shape:
        raise InvalidInputError(f"left and right must be grey (H, W) images of one size, got {left.shape} "
                                f"and {right.shape}")
    _check_box(box, left.shape)
    return np.ascontiguousarray(left, dtype=np.float32), np.ascontiguousarray(right, dtype=np.float32)


def estimate_ground_plane(left: np.ndarray, right: np.ndarray, box: tuple[int, int, int, int], *,
                          params: GroundCheckParameters = GroundCheckParameters()) -> tuple[GroundPlane, int]:
    """The ground plane from patches of the reference area found in the right image.

    Parameters
    ----------
    left, right
        ``float32 (H, W)`` grey images of a rectified pair (:func:`grey_levels`).
    box
        Reference area ``(x0, y0, x1, y1)`` in pixels, end exclusive, assumed to be ground.
    params
        Patch sizes, search range and fit settings.

    Returns
    -------
    (GroundPlane, int)
        The plane and the number of patch disparities it was fitted to.

    Raises
    ------
    InvalidInputError
        Images not of one ``(H, W)`` shape, a box that is not a non-empty rectangle inside them,
        fewer than ``params.plane_fit.min_inliers`` patches matched, no ground-like plane
        (e.g. a wall fills the area, or the area has no texture), or a plane that fits fewer
        than ``params.min_inlier_fraction`` of the patches.
    """
    left, right = _check_grey_pair(left, right, box)
    x0, y0, x1, y1 = box
    w = left.shape[1]
    ry, rx = params.patch_rows_px // 2, params.patch_cols_px // 2
    max_d = max(1, int(params.max_disparity_fraction * w))
    rows = _spread(y0 + ry, y1 - 1 - ry, params.patch_grid[0])
    cols = _spread(x0 + rx, x1 - 1 - rx, params.patch_grid[1])
    centres = np.array([(x, y) for y in rows for x in cols], dtype=np.int64).reshape(-1, 2)
    outcome = np.empty(len(centres), dtype=np.int64)
    disparity = np.empty(len(centres), dtype=np.float64)
    patch_disparities_kernel(left, right, centres, ry, rx, max_d, float(params.min_patch_std),
                             float(params.min_patch_correlation), outcome, disparity)
    found = outcome == PATCH_FOUND
    xs, ys, ds = centres[found, 0], centres[found, 1], disparity[found]
    flat, weak, border = (int(np.count_nonzero(outcome == v)) for v in (PATCH_FLAT, PATCH_WEAK, PATCH_AT_BORDER))
    if len(ds) < params.plane_fit.min_inliers:
        raise InvalidInputError(
            f"reference area {box}: {len(ds)} of {len(rows) * len(cols)} patches found in the right image "
            f"({flat} too flat, {weak} without a clear correlation peak, {border} at the end of the "
            f"disparity search), need {params.plane_fit.min_inliers} to estimate the ground plane")
    plane = fit_plane_points(xs, ys, ds, params=params.plane_fit)
    if plane.inlier_fraction < params.min_inlier_fraction:
        raise InvalidInputError(f"reference area {box}: the ground plane agrees with only {plane.n_inliers} of "
                                f"{len(ds)} patch disparities (need {params.min_inlier_fraction:.0%})")
    return plane, len(ds)


def off_ground_mask(left: np.ndarray, right: np.ndarray, plane: GroundPlane, box: tuple[int, int, int, int], *,
                    params: GroundCheckParameters = GroundCheckParameters()) -> tuple[np.ndarray, float]:
    """Pixels whose window disagrees with the right image read through ``plane``.

    Parameters
    ----------
    left, right
        ``float32 (H, W)`` grey images, 0..255 scale.
    plane
        Ground plane in disparity space.
    box
        Reference area ``(x0, y0, x1, y1)``: its median difference variance is the ground's level.
    params
        Window and thresholds.

    Returns
    -------
    (numpy.ndarray, float)
        ``bool (H, W)`` off-ground mask (False where the plane maps outside the right image
        or has no positive disparity, e.g. above the horizon), and the ground's variance.

    Raises
    ------
    InvalidInputError
        Images not of one ``(H, W)`` shape, or a box that is not a non-empty rectangle inside them.
    """
    left, right = _check_grey_pair(left, right, box)
    x0, y0, x1, y1 = box
    # rows above the plane's horizon have no valid pixel: their windows are not judged, so the
    # work starts half a window above the first row where the plane's disparity can be positive
    top = min(max(0, _first_positive_row(plane, left.shape) - params.window_px // 2), y0)
    terms = np.empty(left.shape + (TERMS,), dtype=np.float32)
    ground_warp_terms_kernel(left, right, plane.a, plane.b, plane.c, params.misalignment_px ** 2,
                             params.row_misalignment_px ** 2, top, terms)
    terms = terms[top:]
    means = cv2.blur(terms, (params.window_px, params.window_px))
    variance = np.empty((y1 - y0, x1 - x0), dtype=np.float32)
    window_variance_kernel(means[y0 - top:y1 - top, x0:x1], MIN_VALID_SHARE, variance)
    reference = variance[(variance >= 0) & (terms[y0 - top:y1 - top, x0:x1, 3] > 0)]
    noise = max(median(reference) if reference.size else 0.0, MIN_NOISE_VARIANCE)
    off = np.zeros(left.shape, dtype=np.bool_)
    off_ground_kernel(terms, means, MIN_VALID_SHARE, np.float32(params.mismatch_factor * noise), off[top:])
    if params.vote_window_px > 1:
        off[top:] = vote(off[top:], terms[..., 3] > 0, params.vote_window_px, params.vote_fraction)
    return off, noise


def _first_positive_row(plane: GroundPlane, shape: tuple[int, int]) -> int:
    """The first row of an ``(H, W)`` image where the plane's disparity ``a x + b y + c`` may be
    positive for some column (0 when the plane does not rise towards the bottom, ``H`` when
    it is nowhere positive); every pixel above it has ``d <= 0``."""
    height, width = shape
    highest_at_row_zero = plane.c + max(0.0, plane.a * (width - 1))
    if highest_at_row_zero > 0.0 or not plane.b > 0.0:
        return 0
    row = -highest_at_row_zero / plane.b           # may overflow to inf for a nearly level plane
    return int(math.floor(row)) if row < height else height


def vote(off: np.ndarray, valid: np.ndarray, window_px: int, fraction: float) -> np.ndarray:
    """``bool (H, W)``: valid pixels whose ``window_px`` square holds more than ``fraction`` of
    ``off`` pixels (counted over the whole square; outside the image counts as not off)."""
    votes = cv2.boxFilter(off.view(np.uint8), cv2.CV_16U, (window_px, window_px), normalize=False,
                          borderType=cv2.BORDER_CONSTANT)
    return valid & (votes > fraction * window_px * window_px)


def check_colour_pair(left_rgb: np.ndarray, right_rgb: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Both images as C-contiguous ``(H, W, 3)`` ``uint8``/``uint16`` arrays of one size and dtype.

    Raises
    ------
    InvalidInputError
        Either image is not such an array (the message names ``left`` or ``right``).
    ImageMismatchError
        They differ in size or dtype.
    """
    left, _ = check_rgb(left_rgb, "left")
    right, _ = check_rgb(right_rgb, "right")
    if left.shape != right.shape or left.dtype != right.dtype:
        raise ImageMismatchError(f"left and right images differ: {left.shape} {left.dtype} vs "
                                 f"{right.shape} {right.dtype}")
    return left, right


def check_ground(left_rgb: np.ndarray, right_rgb: np.ndarray, box: tuple[int, int, int, int], *,
                 params: GroundCheckParameters = GroundCheckParameters()) -> GroundCheck:
    """Estimate the ground plane from the reference area and mark the pixels off it.

    Parameters
    ----------
    left_rgb, right_rgb
        ``uint8`` or ``uint16`` ``(H, W, 3)`` RGB images of a rectified pair, of one size and dtype.
    box
        Reference area ``(x0, y0, x1, y1)`` in pixels, assumed to be ground.
    params
        See :class:`GroundCheckParameters`.

    Returns
    -------
    GroundCheck

    Raises
    ------
    InvalidInputError
        Not ``(H, W, 3)`` ``uint8``/``uint16`` images, a box that is not a non-empty rectangle
        inside the image, or a plane that cannot be estimated (see :func:`estimate_ground_plane`).
    ImageMismatchError
        The images differ in size or dtype.

    Examples
    --------
    >>> import cv2, numpy as np
    >>> rng = np.random.default_rng(1)
    >>> noise = rng.normal(128, 60, (120, 300)).astype(np.float32)
    >>> scene = np.clip(cv2.GaussianBlur(noise, (0, 0), 2) * 3 - 256, 0, 255).astype(np.uint8)
    >>> rows = np.arange(120)[:, None]
    >>> disparity = np.rint(0.2 * rows).astype(int)                     # ground: d = 0.2 y
    >>> cols = np.arange(200)[None, :] + 40
    >>> left, right = scene[rows, cols], scene[rows, cols + disparity]  # left x is right x - d
    >>> left[30:50, 100:120] = right[30:50, 80:100] = scene[:20, 250:270]  # a box at d = 20
    >>> check = check_ground(np.dstack([left] * 3), np.dstack([right] * 3), (0, 90, 200, 120))
    >>> round(check.plane.b, 1), bool(check.off_ground[40, 110]), bool(check.off_ground[100, 110])
    (0.2, True, False)
    """
    left_rgb, right_rgb = check_colour_pair(left_rgb, right_rgb)
    _check_box(box, left_rgb.shape)
    left, right = grey_levels(left_rgb), grey_levels(right_rgb)
    plane, n_patches, plane_box, fallback_reason = _plane_with_fallback(left, right, box, params)
    off_ground, noise = off_ground_mask(left, right, plane, plane_box, params=params)
    logger.debug("ground check: plane %s from %d patches of %s, noise variance %.2f, %.1f %% off the ground",
                 plane, n_patches, plane_box, noise, 100.0 * np.count_nonzero(off_ground) / off_ground.size)
    above = (above_horizon(plane, off_ground.shape, params.horizon_margin_px) if params.horizon_margin_px is not None
             else np.zeros(off_ground.shape, dtype=np.bool_))
    return GroundCheck(plane=plane, off_ground=off_ground, noise_variance=noise, n_patches=n_patches,
                       plane_box=plane_box, fallback_reason=fallback_reason, above_horizon=above)


def above_horizon(plane: GroundPlane, shape: tuple[int, int], margin_px: float) -> np.ndarray:
    """``bool (H, W)``: pixels of an ``(H, W)`` image where the plane's disparity ``a x + b y + c``
    is below ``-margin_px`` (none when ``b <= 0``: the plane does not rise towards the bottom of the
    image as a ground seen from above does).

    A ground plane's disparity falls to 0 at its horizon and is negative above it: no point
    of the ground is seen there, only what stands up from it and the sky. ``margin_px``
    (pixels of disparity) covers the plane's error near the horizon.

    Examples
    --------
    >>> from stereo_obstacles.ground_plane import GroundPlane
    >>> mask = above_horizon(GroundPlane(a=0.0, b=0.1, c=-5.0), (100, 4), 0.5)   # horizon at row 50
    >>> int(mask[:, 0].sum()), bool(mask[44, 0]), bool(mask[45, 0])               # d < -0.5: rows 0..44
    (45, True, False)
    """
    if not (isinstance(shape, tuple) and len(shape) == 2):
        raise InvalidInputError(f"shape must be (H, W), got {shape!r}")
    if not (isinstance(margin_px, (int, float)) and math.isfinite(margin_px) and margin_px >= 0.0):
        raise InvalidInputError(f"margin_px must be a finite number >= 0, got {margin_px!r}")
    height, width = shape
    mask = np.zeros(shape, dtype=np.bool_)
    if not plane.b > 0.0:
        return mask                                  # not a ground seen from above: no horizon to speak of
    column_terms = plane.a * np.arange(width, dtype=np.float64)
    row_terms = plane.b * np.arange(height, dtype=np.float64) + plane.c
    rows = np.flatnonzero(row_terms + column_terms.min(initial=0.0) < -margin_px)
    mask[rows] = row_terms[rows, None] + column_terms[None, :] < -margin_px
    return mask


def _plane_with_fallback(left: np.ndarray, right: np.ndarray, box: tuple[int, int, int, int],
                         params: GroundCheckParameters
                         ) -> tuple[GroundPlane, int, tuple[int, int, int, int], str | None]:
    """The plane from the reference area ``box``, or else from the taller band of
    ``params.fallback_band_factor``; with the patch count, the box used and why the reference
    area failed (None when it did not).

    Raises
    ------
    InvalidInputError
        Neither gives a plane (the message gives both reasons).
    """
    try:
        return (*estimate_ground_plane(left, right, box, params=params), box, None)
    except InvalidInputError as error:
        x0, y0, x1, y1 = box
        taller = (x0, max(0, y1 - int(round(params.fallback_band_factor * (y1 - y0)))), x1, y1)
        if taller[1] == y0:
            raise
        reason = str(error) if str(error).startswith("reference area") else f"reference area {box}: {error}"
    rows = int(round(params.patch_grid[0] * (y1 - taller[1]) / (y1 - y0)))
    try:
        plane, n_patches = estimate_ground_plane(left, right, taller,
                                                 params=replace(params, patch_grid=(rows, params.patch_grid[1])))
    except InvalidInputError as second:
        raise InvalidInputError(f"{reason}; and from the taller band {taller}: {second}") from None
    return plane, n_patches, taller, reason


__all__ = ["GroundCheckParameters", "GroundCheck", "grey_levels", "estimate_ground_plane", "off_ground_mask",
           "above_horizon", "vote", "check_colour_pair", "check_ground"]
