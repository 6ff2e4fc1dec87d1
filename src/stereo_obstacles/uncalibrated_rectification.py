"""Uncalibrated rectification: rectifying homographies from the images alone.

Steps of :func:`rectify_uncalibrated`:

1. feature matches (:func:`stereo_obstacles.feature_matching.match_features`);
2. a robust fundamental matrix ``F`` (``cv2.findFundamentalMat``, MAGSAC++), keeping its inliers;
3. refusal of degenerate input (:class:`~stereo_obstacles.errors.RectificationError`): too few
   inliers, a motion without parallax (a pure rotation, or a single plane: one homography
   explains nearly every match, so ``F`` is not determined), or an epipole inside the image
   (forward motion: no rectification keeps the image whole) -- unless the pair is nearly
   rectified already (:func:`_matches_on_their_rows`: the epipole of such a pair lies at
   infinity, and estimated from a few matches it can land anywhere), which is used as it is
   when those matches lie on their rows to the keypoints' noise and their disparities vary with
   depth (:func:`_usable_as_it_is`), and refused otherwise;
4. Hartley's rectifying homographies ``H1``, ``H2`` (``cv2.stereoRectifyUncalibrated``);
5. the least distortion: rows may be remapped by any common ``y' = a y + c`` and each
   image's columns by its own affine ``x' = d x + e y + g`` without undoing the
   rectification, so those are chosen (least squares over a grid of pixels) to keep each
   rectified image as close as possible to the original -- no shear, no flip, no needless
   scaling or shift. Left pixels then stay near where they were, and disparities keep their
   sign and size.

The quality is reported as the vertical offsets of the inlier matches after rectification (the
inliers of ``F``, or of a nearly rectified pair the matches on their rows).
Without a calibration the rectified pair has no metric scale: depth needs a calibration.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from stereo_obstacles.errors import RectificationError
from stereo_obstacles.feature_matching import match_features
from stereo_obstacles.image_pairs import check_same_size
from stereo_obstacles.rectification import PairMaps
from stereo_obstacles.rectification_quality import VerticalOffsetStats, vertical_offset_stats

logger = logging.getLogger(__name__)

MIN_INLIERS = 30
"""Fewest fundamental-matrix inliers accepted."""

PRIOR_WEIGHT = 1.0
"""Weight of the zero prior on the quasi-Euclidean parameters, pixels of offset per radian."""

MODELS = ("quasi-euclidean", "hartley")
"""Rectifying homographies: rotations of the cameras fitted to the matches, or OpenCV's Hartley method."""

MIN_PARALLAX_FRACTION = 0.05
"""Fewest fundamental-matrix inliers, as a fraction, that a single homography must fail to explain."""

ON_ROW_FRACTION = 0.9
"""A pair whose epipole lands in view is nearly rectified when its matches within the threshold
of their rows number at least this fraction of the fundamental matrix's inliers
(:func:`_matches_on_their_rows`)."""
ON_ROW_PERCENTILE = 5.0
"""... when this percentile of their disparities is at least minus the threshold (and the pair is
swapped when the mirror percentile, 100 minus this, is at most the threshold) ..."""
MIN_ON_ROW_DISPARITY_THRESHOLDS = 2.0
"""... and their median disparity at least this many thresholds (pixels per pixel of threshold)."""
MAX_UNCHANGED_OFFSET_PX = 0.15
"""A nearly rectified pair is used as it is only when the median vertical offset of its matches
on their rows is at most this (pixels: rectified synthetic pairs read 0.03-0.14 px, the
keypoints' noise; a few tenths of a pixel cost the matcher most of its matches, 0.3 px: density
90 -> 57 %) ..."""
MIN_THIRD_SHARE = 0.1
"""... and when each third of the image's width, and two of the thirds of its height, hold at
least this fraction of those matches (rows without matches cannot be vouched for: a rolled
camera left seed 8's right third, with one match, 0.2-0.4 px off; a camera toed in by 2-3
degrees left the top and bottom rows of small images 1-2 px off where only the middle rows had
matches; reviews. A street scene's sky has no matches, so one third of the height may lack them)
..."""
MAX_THIRD_OFFSET_PX = 0.15
"""... and when their signed vertical offsets have a median of at most this (pixels, either way)
in each third of the width or height holding ``MIN_THIRD_SHARE`` of them (a tilt, a shift and a
focal length a little off left the middle rows 0.26-0.33 px off while most matches lay in the
bottom rows, near 0: a review) ..."""
MAX_CELL_OFFSET_PX = 0.2
"""... and when their signed vertical offsets have a median of at most this (pixels, either way)
in each cell of the 3 x 3 grid of thirds holding ``MIN_CELL_MATCHES`` of them or more (rectified
pairs: within 0.16 px; a roll and a shift can cancel where most matches lie and leave the rest of
the image 0.5-1 px off, and a toe-in's keystone cancels along a row or a column of cells:
reviews) ..."""
MIN_CELL_MATCHES = 8
MIN_UNCHANGED_MATCHES = 50
"""... and when there are at least this many of those matches, enough to vouch for the image
(toed-in cameras of 160 x 120 images passed with 30-41, a review; rectified synthetic pairs
have 32-122) ..."""
MIN_DEPTH_RELIEF_THRESHOLDS = 0.6
"""... and when their disparities vary with depth: matches within ``RELIEF_COLUMN_PX`` columns of
each other differ in disparity by at least this many thresholds (median over such pairs). A
camera turned about its vertical axis, without a baseline, also moves the matches along their
rows, by an amount that follows the column (a zoom: too): 0.06-0.37 px for pans of 0.7-3 degrees
with a 1 mm baseline (scenes 1..8 at 320x240 with 30 matches or more), against 0.77-8.7 px for
rectified pairs (nine scenes at two sizes). Pairs of matches, not a fit: one mismatch along its
row swayed a fitted curve (a review)."""
RELIEF_COLUMN_PX = 8.0
RELIEF_NEIGHBOURS = 10
"""Each match is compared with at most this many next ones in column order."""


@dataclass(frozen=True, eq=False)
class UncalibratedRectification:
    """Rectifying homographies of one uncalibrated pair, with their quality.

    Attributes
    ----------
    h_left, h_right : ndarray, shape (3, 3)
        Homographies from original to rectified pixel coordinates.
    fundamental : ndarray, shape (3, 3)
        ``F`` with ``x_right^T F x_left = 0``, as estimated (not used for a pair taken as
        rectified already, whose epipole estimate landed in view).
    n_matches, n_inliers : int
        Putative feature matches, and the inliers of ``F`` (of a nearly rectified pair whose
        epipole estimate lands in view: its matches on their rows, module docstring).
    quality : VerticalOffsetStats
        Vertical offsets of the inliers after rectification.
    disparity_range_px : tuple of float
        1st and 99th percentiles of the inliers' disparities after rectification (a search range).
    maps : PairMaps
        Look-up maps for :meth:`apply`.
    """

    h_left: np.ndarray
    h_right: np.ndarray
    fundamental: np.ndarray
    n_matches: int
    n_inliers: int
    quality: VerticalOffsetStats
    disparity_range_px: tuple[float, float]
    maps: PairMaps

    @property
    def unchanged(self) -> bool:
        """True when both homographies are identities: the pair was rectified already and is used
        as it is."""
        return bool(np.array_equal(self.h_left, np.eye(3)) and np.array_equal(self.h_right, np.eye(3)))

    def apply(self, left: np.ndarray, right: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Rectify the pair (or another frame of the same rig); see :meth:`PairMaps.apply`."""
        return self.maps.apply(left, right)

    def left_points(self, points_px: np.ndarray) -> np.ndarray:
        """Rectified coordinates ``(N, 2)`` of original left image points ``(N, 2)``."""
        return _transform(self.h_left, points_px)

    def right_points(self, points_px: np.ndarray) -> np.ndarray:
        """Rectified coordinates ``(N, 2)`` of original right image points ``(N, 2)``."""
        return _transform(self.h_right, points_px)

    def to_dict(self) -> dict:
        """JSON-ready summary: homographies, counts, quality."""
        return {"method": "uncalibrated", "h_left": self.h_left.tolist(), "h_right": self.h_right.tolist(),
                "fundamental": self.fundamental.tolist(), "n_matches": self.n_matches,
                "n_inliers": self.n_inliers, "vertical_offset": self.quality.to_dict(),
                "disparity_range_px": list(self.disparity_range_px)}


def _transform(h: np.ndarray, points_px: np.ndarray) -> np.ndarray:
    points = np.asarray(points_px, dtype=np.float64).reshape(-1, 2)
    mapped = np.c_[points, np.ones(len(points))] @ h.T
    return mapped[:, :2] / mapped[:, 2:3]


def _grid(width: int, height: int, n: int = 9) -> np.ndarray:
    xs, ys = np.meshgrid(np.linspace(0, width - 1, n), np.linspace(0, height - 1, n))
    return np.c_[xs.ravel(), ys.ravel()]


def _least_distortion(h_left: np.ndarray, h_right: np.ndarray, width: int, height: int
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Compose each homography with the row-preserving affine that keeps the image closest to itself."""
    grid = _grid(width, height)
    mapped_left, mapped_right = _transform(h_left, grid), _transform(h_right, grid)
    ones = np.ones(len(grid))
    # Rows: one y' = a y + c for both images (a term in x would add a multiple of the disparity).
    design_y = np.r_[np.c_[mapped_left[:, 1], ones], np.c_[mapped_right[:, 1], ones]]
    row = np.linalg.lstsq(design_y, np.r_[grid[:, 1], grid[:, 1]], rcond=None)[0]
    adjusted = []
    for h, mapped in ((h_left, mapped_left), (h_right, mapped_right)):
        column = np.linalg.lstsq(np.c_[mapped[:, 0], mapped[:, 1], ones], grid[:, 0], rcond=None)[0]
        affine = np.array([column, [0.0, row[0], row[1]], [0.0, 0.0, 1.0]])
        adjusted.append(affine @ h)
    return adjusted[0] / adjusted[0][2, 2], adjusted[1] / adjusted[1][2, 2]


def _rotation(rx: float, ry: float, rz: float) -> np.ndarray:
    cx, sx, cy, sy, cz, sz = np.cos(rx), np.sin(rx), np.cos(ry), np.sin(ry), np.cos(rz), np.sin(rz)
    return (np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]]) @ np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
            @ np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]]))


def _quasi_euclidean_homographies(params: np.ndarray, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """``H = K R K^-1`` per camera (shared ``K``), the right one also shifted down by ``params[6]`` pixels.

    ``params``: left yaw, left roll, right pitch, right yaw, right roll (radians), log focal
    factor, right vertical shift (pixels).
    """
    focal = (width + height) / 2.0 * np.exp(params[5])
    k = np.array([[focal, 0.0, (width - 1) / 2.0], [0.0, focal, (height - 1) / 2.0], [0.0, 0.0, 1.0]])
    k_inv = np.linalg.inv(k)
    shift = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, params[6]], [0.0, 0.0, 1.0]])
    return (k @ _rotation(0.0, params[0], params[1]) @ k_inv,
            shift @ k @ _rotation(params[2], params[3], params[4]) @ k_inv)


def _quasi_euclidean(left: np.ndarray, right: np.ndarray, width: int, height: int,
                     iterations: int = 30) -> tuple[np.ndarray, np.ndarray]:
    """Rotation-only rectifying homographies minimising the inliers' vertical offsets (Gauss-Newton).

    A weak prior (:data:`PRIOR_WEIGHT`) pulls every angle and the focal factor to zero, so the
    directions the matches barely constrain (a far epipole, pitch against vertical shift) stay
    at no rotation instead of wandering off.
    """
    prior = PRIOR_WEIGHT * np.sqrt(len(left))

    def residuals(params: np.ndarray) -> np.ndarray:
        h_left, h_right = _quasi_euclidean_homographies(params, width, height)
        dy = _transform(h_left, left)[:, 1] - _transform(h_right, right)[:, 1]
        return np.r_[dy, prior * params[:6]]

    params = np.zeros(7)
    current = residuals(params)
    for _ in range(iterations):
        jacobian = np.empty((current.size, params.size))
        for j in range(params.size):
            step = np.zeros_like(params)
            step[j] = 1e-7
            jacobian[:, j] = (residuals(params + step) - residuals(params - step)) / 2e-7
        update = np.linalg.lstsq(jacobian, -current, rcond=None)[0]
        scale = 1.0
        while scale > 1e-3:
            trial = residuals(params + scale * update)
            if trial @ trial < current @ current:
                break
            scale /= 2
        else:
            break
        gain = current @ current - trial @ trial
        params, current = params + scale * update, trial
        if gain < 1e-6 * (current @ current):
            break
    return _quasi_euclidean_homographies(params, width, height)


def _homography_maps(h: np.ndarray, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    xs, ys = np.meshgrid(np.arange(width, dtype=np.float64), np.arange(height, dtype=np.float64))
    source = _transform(np.linalg.inv(h), np.c_[xs.ravel(), ys.ravel()])
    return (source[:, 0].reshape(height, width).astype(np.float32),
            source[:, 1].reshape(height, width).astype(np.float32))


def _check_parallax(left: np.ndarray, right: np.ndarray, threshold_px: float) -> None:
    import cv2

    _, plane = cv2.findHomography(left, right, cv2.USAC_MAGSAC, threshold_px)
    off_plane = 1.0 - float(np.count_nonzero(plane)) / len(left) if plane is not None else 1.0
    if off_plane < MIN_PARALLAX_FRACTION:
        raise RectificationError(
            f"degenerate motion: one homography explains {100 * (1 - off_plane):.1f} % of the matches (a pure "
            f"rotation, no baseline, or a single flat surface), so the epipolar geometry is not determined; "
            f"move the cameras apart or show a scene with depth")


def _fundamental_matrix(left: np.ndarray, right: np.ndarray, threshold_px: float) -> tuple:
    """``cv2.findFundamentalMat`` of the matches (``(N, 2)`` pixels) by MAGSAC++.

    Raises
    ------
    RectificationError
        MAGSAC++ raises its assertion that some sample gave a model (a zoomed copy, a pair nearly
        rectified with a camera slightly rolled, pure rotations of small images: session 26; a
        RANSAC fallback accepted such pairs with poor or no rectification, a review).
    """
    import cv2

    try:
        return cv2.findFundamentalMat(left, right, cv2.USAC_MAGSAC, threshold_px, 0.999)
    except cv2.error as error:
        raise RectificationError(f"OpenCV estimates no epipolar geometry from the {len(left)} feature matches "
                                 f"(the pair may have no baseline, or be nearly rectified with a camera slightly "
                                 f"turned); calibrate the cameras instead") from error


def _epipole_near_image(fundamental: np.ndarray, width: int, height: int) -> tuple[float, float] | None:
    """The left epipole ``(x, y)``, pixels, when it lies in or near the image (within half the
    image's size of it: the motion is forward), else None."""
    epipole = np.linalg.svd(fundamental)[2][-1]     # the right null vector of F
    if abs(epipole[2]) <= 1e-12:
        return None
    x, y = epipole[:2] / epipole[2]
    inside = -0.5 * width <= x <= 1.5 * width and -0.5 * height <= y <= 1.5 * height
    return (float(x), float(y)) if inside else None


def _matches_on_their_rows(left: np.ndarray, right: np.ndarray, threshold_px: float, n_inliers: int,
                           min_inliers: int) -> np.ndarray | None:
    """``bool (N,)``: the matches (``(N, 2)`` pixels of the images as given) within
    ``threshold_px`` of their row, when they show a pair that is nearly rectified; else None.

    Nearly rectified means: these matches number at least ``min_inliers`` and at least
    ``ON_ROW_FRACTION`` of ``n_inliers``, the fundamental matrix's inliers (the rows explain
    nearly as much as ``F`` does); the ``ON_ROW_PERCENTILE`` percentile of their disparities is
    at least ``-threshold_px``; and their median disparity is at least
    ``MIN_ON_ROW_DISPARITY_THRESHOLDS`` thresholds (a baseline, not a static camera with things
    moving in front of it). A camera moved forward moves its matches off their rows above and
    below the epipole and to negative disparities on one side of it; a zoom moves them both
    ways along the rows (measured in ``docs/rectification.md``).

    Raises
    ------
    RectificationError
        The matches on their rows lie at negative disparities (the mirror image of the rule):
        the images look swapped.
    """
    offsets = right - left
    on_row = np.abs(offsets[:, 1]) <= threshold_px
    if np.count_nonzero(on_row) < max(min_inliers, ON_ROW_FRACTION * n_inliers):
        return None
    disparities = -offsets[on_row, 0]
    least = MIN_ON_ROW_DISPARITY_THRESHOLDS * threshold_px
    median = float(np.median(disparities))
    if median <= -least and np.percentile(disparities, 100 - ON_ROW_PERCENTILE) <= threshold_px:
        raise RectificationError(f"the matches lie on their rows at negative disparities (median {median:.1f} px): "
                                 f"the left and right images look swapped")
    if np.percentile(disparities, ON_ROW_PERCENTILE) < -threshold_px or median < least:
        return None
    return on_row


def _usable_as_it_is(left: np.ndarray, right: np.ndarray, threshold_px: float, width: int,
                     height: int) -> str | None:
    """Why a nearly rectified pair (its matches on their rows, ``(N, 2)`` pixels, in an image of
    ``width`` x ``height`` pixels) cannot be used as it is, or None when it can
    (``MIN_UNCHANGED_MATCHES``, ``MAX_UNCHANGED_OFFSET_PX``, ``MIN_THIRD_SHARE``,
    ``MAX_THIRD_OFFSET_PX``, ``MAX_CELL_OFFSET_PX``, ``MIN_DEPTH_RELIEF_THRESHOLDS``)."""
    offsets_px = right[:, 1] - left[:, 1]
    if len(left) < MIN_UNCHANGED_MATCHES:
        return f"only {len(left)} of its matches lie on their rows ({MIN_UNCHANGED_MATCHES} are needed to vouch for it)"
    if np.median(np.abs(offsets_px)) > MAX_UNCHANGED_OFFSET_PX:
        return f"its matches lie {np.median(np.abs(offsets_px)):.2f} px off their rows (median)"
    column = np.minimum((3 * left[:, 0] / width).astype(int), 2)
    row = np.minimum((3 * left[:, 1] / height).astype(int), 2)
    share = MIN_THIRD_SHARE * len(left)
    columns_covered = np.count_nonzero(np.bincount(column, minlength=3) >= share)
    rows_covered = np.count_nonzero(np.bincount(row, minlength=3) >= share)
    if columns_covered < 3 or rows_covered < 2:
        return (f"its {len(left)} matches on their rows cover {columns_covered} of the thirds of the image's width "
                f"and {rows_covered} of its height, too few to vouch for its rows")
    for parts, least, most_px, name in ((column, share, MAX_THIRD_OFFSET_PX, "a third"),
                                        (row, share, MAX_THIRD_OFFSET_PX, "a third"),
                                        (3 * row + column, MIN_CELL_MATCHES, MAX_CELL_OFFSET_PX, "a ninth")):
        worst_px = max((abs(float(np.median(offsets_px[parts == k]))) for k in np.unique(parts)
                        if np.count_nonzero(parts == k) >= least), default=0.0)
        if worst_px > most_px:
            return f"its matches lie {worst_px:.2f} px off their rows in {name} of the image (median)"
    order = np.argsort(left[:, 0])
    columns, disparities = left[order, 0], (left[:, 0] - right[:, 0])[order]
    steps = [np.abs(disparities[k:] - disparities[:-k])[columns[k:] - columns[:-k] <= RELIEF_COLUMN_PX]
             for k in range(1, min(RELIEF_NEIGHBOURS, len(columns) - 1) + 1)]
    relief_px = float(np.median(np.concatenate(steps))) if sum(step.size for step in steps) else 0.0
    if relief_px < MIN_DEPTH_RELIEF_THRESHOLDS * threshold_px:
        return (f"matches in the same columns share their disparity (within {relief_px:.2f} px, median): a camera "
                f"turned or zoomed without a baseline")
    return None


def rectify_uncalibrated(left: np.ndarray, right: np.ndarray, *, method: str = "sift", ratio: float = 0.75,
                         threshold_px: float = 1.0, min_inliers: int = MIN_INLIERS,
                         model: str = "quasi-euclidean") -> UncalibratedRectification:
    """Rectify a pair from unknown cameras by feature matching and its epipolar geometry.

    Parameters
    ----------
    left, right : ndarray, shape (H, W) or (H, W, 3)
        The original images, same size.
    method : {"sift", "orb"}
        Feature detector.
    ratio : float
        Lowe's ratio test of the matching.
    threshold_px : float
        Largest distance from its epipolar line, pixels, for a match to be an inlier of ``F``.
    min_inliers : int
        Fewest inliers accepted (at least 8).
    model : {"quasi-euclidean", "hartley"}
        How the rectifying homographies are found (see the module docstring).

    Returns
    -------
    UncalibratedRectification

    Raises
    ------
    RectificationError
        Too few matches or inliers, or a degenerate motion (see the module docstring).
    ImageMismatchError
        The images differ in size.
    InvalidInputError
        Not images, or an option out of range.

    Examples
    --------
    >>> from stereo_obstacles.synthetic import RenderOptions, RightCameraError, default_scene, render_pair
    >>> pair = render_pair(default_scene(320, 240), RenderOptions(right_error=RightCameraError(
    ...     rotation_deg=(0.5, 0.0, 0.5), vertical_offset_px=2.0)))       # doctest: +SKIP
    >>> rectify_uncalibrated(pair.left, pair.right).quality.median_px < 0.5  # doctest: +SKIP
    True
    """
    import cv2

    from stereo_obstacles.errors import InvalidInputError

    if model not in MODELS:
        raise InvalidInputError(f"model: expected one of {list(MODELS)}, got {model!r}")
    if not threshold_px > 0:
        raise InvalidInputError(f"threshold_px: expected > 0, got {threshold_px}")
    if int(min_inliers) != min_inliers or min_inliers < 8:
        raise InvalidInputError(f"min_inliers: expected an integer >= 8, got {min_inliers}")
    check_same_size(left, right)
    height, width = left.shape[:2]
    matches = match_features(left, right, method=method, ratio=ratio)
    if len(matches) < min_inliers:
        raise RectificationError(f"too few feature matches to rectify: {len(matches)} (need {min_inliers}); "
                                 f"the images may not overlap, be too plain, or be too different")
    fundamental, mask = _fundamental_matrix(matches.left_px, matches.right_px, threshold_px)
    inlier = mask.ravel().astype(bool) if mask is not None else np.zeros(len(matches), bool)
    if fundamental is None or fundamental.shape != (3, 3) or np.count_nonzero(inlier) < min_inliers:
        raise RectificationError(f"too few matches agree on one epipolar geometry: {np.count_nonzero(inlier)} "
                                 f"of {len(matches)} (need {min_inliers})")
    left_in, right_in = matches.left_px[inlier], matches.right_px[inlier]
    _check_parallax(left_in, right_in, threshold_px)
    epipole = _epipole_near_image(fundamental, width, height)
    if epipole is not None:
        degenerate = (f"degenerate motion: the epipole ({epipole[0]:.0f}, {epipole[1]:.0f}) px is in or near the "
                      f"image, so the cameras are not side by side (forward motion)")
        on_row = _matches_on_their_rows(matches.left_px, matches.right_px, threshold_px, len(left_in), min_inliers)
        if on_row is None:
            raise RectificationError(f"{degenerate}; such a pair cannot be rectified for stereo matching")
        left_in, right_in = matches.left_px[on_row], matches.right_px[on_row]
        reason = _usable_as_it_is(left_in, right_in, threshold_px, width, height)
        if reason is not None:
            raise RectificationError(f"{degenerate}, or the pair is nearly rectified and its epipole cannot be "
                                     f"placed from {len(left_in)} matches on their rows, but {reason}; calibrate "
                                     f"the cameras instead")
        logger.info("the epipole estimated at (%.0f, %.0f) px is unreliable: %d of the %d matches lie on their "
                    "rows, so the pair is taken as rectified", *epipole, len(left_in), len(matches))
        h_left, h_right = np.eye(3), np.eye(3)
    elif model == "hartley":
        ok, h_left, h_right = cv2.stereoRectifyUncalibrated(left_in, right_in, fundamental, (width, height),
                                                            threshold=threshold_px)
        if not ok:
            raise RectificationError("OpenCV found no rectifying homographies for this epipolar geometry")
        h_left, h_right = _least_distortion(h_left, h_right, width, height)
    else:
        h_left, h_right = _least_distortion(*_quasi_euclidean(left_in, right_in, width, height), width, height)
    rect_left, rect_right = _transform(h_left, left_in), _transform(h_right, right_in)
    quality = vertical_offset_stats(rect_left, rect_right)
    disparities = rect_left[:, 0] - rect_right[:, 0]
    low, high = np.percentile(disparities, [1, 99])
    if np.median(disparities) < 0:
        raise RectificationError(f"after rectification the disparities are negative (median "
                                 f"{np.median(disparities):.1f} px): the left and right images look swapped")
    maps = PairMaps(*_homography_maps(h_left, width, height), *_homography_maps(h_right, width, height))
    logger.info("uncalibrated rectification: %d inliers of %d matches, %s", len(left_in), len(matches),
                quality.describe())
    return UncalibratedRectification(h_left=h_left, h_right=h_right, fundamental=fundamental,
                                     n_matches=len(matches), n_inliers=int(len(left_in)), quality=quality,
                                     disparity_range_px=(float(low), float(high)), maps=maps)
