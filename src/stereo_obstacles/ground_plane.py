"""The ground as a plane in disparity space, fitted robustly: ``d = a x + b y + c``.

For a rectified pair looking at a flat ground, the ground's disparity is an affine function of
the pixel position (it is zero at the horizon and grows towards the bottom of the image). The
fit is RANSAC on minimal samples of three points followed by least squares on the inliers,
repeated until the inlier set stops changing. Obstacles are what lies clearly in front of the
plane (larger disparity); markings and puddles lie on it.

Used by the KITTI segmentation ground truth (:mod:`stereo_obstacles.segmentation_evaluation`)
and by phase 3 (height above ground, flat groups).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from stereo_obstacles._ground_plane_kernel import inlier_counts_kernel, masked_points_kernel, raised_pixels_kernel
from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import plain_numbers

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class GroundPlane:
    """``d = a x + b y + c`` in pixels (``x`` column, ``y`` row, ``d`` disparity).

    Attributes
    ----------
    a, b, c
        Coefficients: ``a`` and ``b`` are pixels of disparity per pixel, ``c`` pixels.
    n_inliers
        Points within the inlier threshold of the final plane.
    inlier_fraction
        ``n_inliers`` over the points fitted.
    rms_px
        Root mean square residual of the inliers, pixels.
    """

    a: float
    b: float
    c: float
    n_inliers: int = 0
    inlier_fraction: float = 0.0
    rms_px: float = 0.0

    def __post_init__(self) -> None:
        if not all(math.isfinite(v) for v in (self.a, self.b, self.c, self.inlier_fraction, self.rms_px)):
            raise InvalidInputError(f"GroundPlane values must be finite, got {self}")

    def disparity_at(self, x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray:
        """Disparity of the plane at columns ``x`` and rows ``y`` (broadcast), ``float64``."""
        return self.a * np.asarray(x, dtype=np.float64) + self.b * np.asarray(y, dtype=np.float64) + self.c

    def disparity_map(self, height: int, width: int) -> np.ndarray:
        """``float32 (height, width)`` disparity of the plane at every pixel."""
        ys, xs = np.mgrid[0:height, 0:width]
        return self.disparity_at(xs, ys).astype(np.float32)

    def residual_map(self, disparity: np.ndarray) -> np.ndarray:
        """``disparity - plane`` as ``float32 (H, W)``; positive = in front of the ground; NaN stays NaN."""
        d = _check_disparity(disparity)
        return (d - self.disparity_map(*d.shape)).astype(np.float32)


REFIT_POINTS = 20000
"""The least-squares refits of the RANSAC plane use at most this many random points (a plane of
three parameters is fixed to far better than the disparity noise by them); the inliers reported
are counted over all points."""


@dataclass(frozen=True)
class PlaneFitParameters:
    """RANSAC settings.

    Attributes
    ----------
    inlier_threshold_px
        A point is an inlier when ``|d - plane| <=`` this, pixels of disparity.
    iterations
        Random minimal samples tried.
    max_points
        Points scored per sample (a random subset when there are more); the least-squares
        refits use up to :data:`REFIT_POINTS`, the inlier count all points.
    min_inliers
        Error when the best plane has fewer inliers than this.
    min_slope_y
        Reject candidate planes with ``b`` below this (pixels of disparity per row). A flat
        ground has ``b = B / h`` (baseline over camera height: 0.33 on KITTI, about 0.08 for a
        chest-mounted 12 cm rig), a wall ``b`` near 0. None accepts any plane.
    seed
        Random generator seed (results are reproducible).
    """

    inlier_threshold_px: float = 1.0
    iterations: int = 300
    max_points: int = 5000
    min_inliers: int = 50
    min_slope_y: float | None = 0.01
    seed: int = 0

    def __post_init__(self) -> None:
        plain_numbers(self)                      # NumPy scalars as Python numbers (JSON-ready)
        if not (math.isfinite(self.inlier_threshold_px) and self.inlier_threshold_px > 0):
            raise InvalidInputError(f"inlier_threshold_px must be > 0, got {self.inlier_threshold_px!r}")
        for name in ("iterations", "max_points", "min_inliers"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 3:
                raise InvalidInputError(f"{name} must be an integer >= 3, got {value!r}")
        if self.min_slope_y is not None and not math.isfinite(self.min_slope_y):
            raise InvalidInputError(f"min_slope_y must be finite or None, got {self.min_slope_y!r}")


def _check_disparity(disparity: np.ndarray) -> np.ndarray:
    d = np.asarray(disparity)
    if d.ndim != 2 or not np.issubdtype(d.dtype, np.floating):
        raise InvalidInputError(f"disparity must be a float (H, W) array, got {d.dtype} {d.shape}")
    return d


def _dot(u: np.ndarray, v: np.ndarray) -> float:
    """``sum(u * v)`` of two 1-D arrays without BLAS.

    The per-frame geometry here avoids NumPy's BLAS calls (``@``, ``dot``): OpenBLAS threads a
    dot product of a few thousand elements, and its threads then spin, competing with the
    matcher's threads; on the busy 2-core machine a 20,000-point refit took 17 ms through BLAS
    and under 1 ms without it (``docs/pipeline.md``, "Speed").
    """
    return float(np.sum(u * v))


def _least_squares(x: np.ndarray, y: np.ndarray, d: np.ndarray) -> np.ndarray:
    """``(a, b, c)`` minimising ``sum (a x + b y + c - d)**2``, by the 3x3 normal equations
    on centred coordinates (well conditioned, and far faster than a QR of an (n, 3) matrix)."""
    mx, my, md = x.mean(), y.mean(), d.mean()
    cx, cy, cd = x - mx, y - my, d - md
    sxy = _dot(cx, cy)
    gram = np.array([[_dot(cx, cx), sxy], [sxy, _dot(cy, cy)]])
    if np.linalg.det(gram) <= 1e-9 * max(float(np.trace(gram)) ** 2, 1e-300):
        raise InvalidInputError("the plane's points are (nearly) collinear; no plane is defined by them")
    a, b = np.linalg.solve(gram, np.array([_dot(cx, cd), _dot(cy, cd)]))
    return np.array([a, b, md - a * mx - b * my])


WALL_FIT_RATIO = 0.5
"""When the least-squares plane of the best ground-like candidate's inliers is not ground-like and
fits them better than this fraction of the candidate's error (root mean square), the points are
one plane that only the slope constraint tilted into a ground: a wall filling the view. A ground
with some wall points among its inliers fits its candidate about as well as the refit does."""


def fit_plane_points(x: np.ndarray, y: np.ndarray, d: np.ndarray, *,
                     params: PlaneFitParameters = PlaneFitParameters()) -> GroundPlane:
    """Fit ``d = a x + b y + c`` to points robustly (RANSAC, then least squares on inliers).

    Parameters
    ----------
    x, y, d
        1-D arrays of one length: columns, rows and disparities (pixels), all finite.
    params
        RANSAC settings.

    Returns
    -------
    GroundPlane

    Raises
    ------
    InvalidInputError
        Mismatched or non-finite input, fewer than 3 points, or no plane with
        ``params.min_inliers`` inliers.

    Examples
    --------
    >>> import numpy as np
    >>> ys, xs = np.mgrid[200:300, 0:400]
    >>> d = 0.01 * xs + 0.2 * ys - 30.0
    >>> d[:20] += 15.0                      # an obstacle in front of the ground
    >>> plane = fit_plane_points(xs.ravel(), ys.ravel(), d.ravel())
    >>> round(plane.a, 4), round(plane.b, 4), round(plane.c, 2)
    (0.01, 0.2, -30.0)
    """
    xs, ys, ds = (np.asarray(v, dtype=np.float64) for v in (x, y, d))
    if xs.ndim != 1 or xs.shape != ys.shape or xs.shape != ds.shape:
        raise InvalidInputError(f"x, y, d must be 1-D of one length, got {xs.shape}, {ys.shape}, {ds.shape}")
    if not (np.all(np.isfinite(xs)) and np.all(np.isfinite(ys)) and np.all(np.isfinite(ds))):
        raise InvalidInputError("x, y, d must be finite (drop pixels without disparity first)")
    n = xs.size
    if n < max(3, params.min_inliers):
        raise InvalidInputError(f"need at least {max(3, params.min_inliers)} points to fit a plane, got {n}")
    rng = np.random.default_rng(params.seed)
    scored = rng.choice(n, size=params.max_points, replace=False) if n > params.max_points else np.arange(n)
    samples = rng.integers(0, n, size=(params.iterations, 3))
    systems = np.stack([xs[samples], ys[samples], np.ones(samples.shape)], axis=-1)
    usable = np.abs(np.linalg.det(systems)) > 1e-6
    candidates = np.zeros((params.iterations, 3))
    candidates[usable] = np.linalg.solve(systems[usable], ds[samples][usable][..., None])[..., 0]
    if params.min_slope_y is not None:
        usable &= candidates[:, 1] >= params.min_slope_y
    if not usable.any():
        raise InvalidInputError("no usable plane sample (points collinear, or no plane slopes like a ground)")
    planes = np.ascontiguousarray(candidates[usable])
    counts, _ = inlier_counts_kernel(planes, xs[scored], ys[scored], ds[scored], float(params.inlier_threshold_px))
    best = planes[np.argmax(counts)]
    refit_points = rng.choice(n, size=REFIT_POINTS, replace=False) if n > REFIT_POINTS else np.arange(n)
    rx, ry, rd = xs[refit_points], ys[refit_points], ds[refit_points]
    refit_inliers = np.abs(best[0] * rx + best[1] * ry + best[2] - rd) <= params.inlier_threshold_px
    for _ in range(10):
        if refit_inliers.sum() < 3:
            break
        refit = _least_squares(rx[refit_inliers], ry[refit_inliers], rd[refit_inliers])
        if params.min_slope_y is not None and refit[1] < params.min_slope_y:
            inl = refit_inliers
            misfit = np.sqrt(np.mean((best[0] * rx[inl] + best[1] * ry[inl] + best[2] - rd[inl]) ** 2))
            flat_fit = np.sqrt(np.mean((refit[0] * rx[inl] + refit[1] * ry[inl] + refit[2] - rd[inl]) ** 2))
            if flat_fit < WALL_FIT_RATIO * misfit:
                raise InvalidInputError("the points lie on a plane that does not slope like a ground "
                                        f"(b = {refit[1]:.4f} px per row: a wall or an object filling the view)")
            break  # the inliers mix in a wall; keep the last ground-like plane
        best = refit
        new_inliers = np.abs(best[0] * rx + best[1] * ry + best[2] - rd) <= params.inlier_threshold_px
        if np.array_equal(new_inliers, refit_inliers):
            break
        refit_inliers = new_inliers
    count, squares = inlier_counts_kernel(best[None, :], xs, ys, ds, float(params.inlier_threshold_px))
    n_inliers = int(count[0])
    if n_inliers < max(3, params.min_inliers):
        raise InvalidInputError(f"no ground plane found: best plane has {n_inliers} "
                                f"inliers, need {params.min_inliers}")
    plane = GroundPlane(a=float(best[0]), b=float(best[1]), c=float(best[2]), n_inliers=n_inliers,
                        inlier_fraction=n_inliers / n, rms_px=float(np.sqrt(squares[0] / n_inliers)))
    logger.debug("ground plane %s", plane)
    return plane


def fit_ground_plane(disparity: np.ndarray, *, mask: np.ndarray | None = None,
                     params: PlaneFitParameters = PlaneFitParameters()) -> GroundPlane:
    """Fit the ground plane to a disparity map (NaN = no disparity), optionally within a mask.

    Parameters
    ----------
    disparity
        ``float (H, W)`` disparity in pixels, NaN where unknown.
    mask
        Optional ``bool (H, W)``: only these pixels are candidates (e.g. the lower half).
    params
        RANSAC settings.

    Returns
    -------
    GroundPlane

    Raises
    ------
    InvalidInputError
        Bad arrays or no plane found (see :func:`fit_plane_points`).
    """
    d = _check_disparity(disparity)
    if mask is None:
        m = np.ones(d.shape, dtype=bool)
    else:
        m = np.asarray(mask)
        if m.dtype != bool or m.shape != d.shape:
            raise InvalidInputError(f"mask must be bool {d.shape}, got {m.dtype} {m.shape}")
    xs, ys, ds = masked_points_kernel(d, m)
    return fit_plane_points(xs, ys, ds, params=params)


def _normal_camera(ground: GroundPlane, calibration: StereoCalibration) -> np.ndarray:
    """Normal ``n`` of the 3-D plane ``n . P = f B`` that the disparity plane describes.

    Substituting ``x = f X / Z + cx``, ``y = f Y / Z + cy`` and ``d + doffs = f B / Z`` into
    ``d = a x + b y + c`` gives ``n = (a f, b f, a cx + b cy + c + doffs)`` in the left camera
    frame (X right, Y down, Z forward); the camera centre lies on the positive side.
    """
    f = calibration.focal_px
    return np.array([ground.a * f, ground.b * f,
                     ground.a * calibration.cx_px + ground.b * calibration.cy_px + ground.c + calibration.doffs_px])


def height_above_ground_m(ground: GroundPlane, points_m: np.ndarray, calibration: StereoCalibration) -> np.ndarray:
    """Signed height of 3-D points (``(..., 3)`` metres, left camera frame) above the ground.

    Positive on the camera's side of the plane.
    """
    normal = _normal_camera(ground, calibration)
    p = np.asarray(points_m, dtype=np.float64)
    along_normal = p[..., 0] * normal[0] + p[..., 1] * normal[1] + p[..., 2] * normal[2]  # no BLAS: see _dot
    return (calibration.focal_baseline_px_m - along_normal) / np.linalg.norm(normal)


def raised_pixels(ground: GroundPlane, disparity: np.ndarray, mask: np.ndarray,
                  calibration: StereoCalibration | None, *, min_height_m: float = 0.0,
                  min_excess_px: float | np.ndarray = 0.0, strict: bool = False) -> np.ndarray:
    """Pixels of ``mask`` whose disparity puts them above the ground plane.

    Parameters
    ----------
    ground
        The plane in disparity space.
    disparity
        ``float32 (H, W)`` disparity in pixels, NaN where unknown.
    mask
        ``bool (H, W)``: the pixels to test.
    calibration
        With it, a pixel must also stand ``min_height_m`` metres above the plane, with
        ``d + doffs > 0``; without it only the disparity test applies. The height is
        :func:`height_above_ground_m` of the pixel's 3-D point, computed without forming the
        point: with ``Z = f B / (d + doffs)``, ``n . P = Z (plane(x, y) + doffs)``, so the
        height is ``f B (d - plane(x, y)) / ((d + doffs) |n|)``.
    min_height_m
        Height in metres (``>``, or ``>=`` unless ``strict``).
    min_excess_px
        Disparity above the plane's, pixels (``>=``): one number, or ``float (H, W)`` per pixel.
    strict
        Use ``>`` for the height test.

    Returns
    -------
    numpy.ndarray
        ``bool (H, W)``.
    """
    d = np.asarray(disparity, dtype=np.float32)
    m = np.asarray(mask, dtype=bool)
    if d.ndim != 2 or m.shape != d.shape:
        raise InvalidInputError(f"disparity {d.shape} and mask {m.shape} must be the same 2-D shape")
    scale, doffs = math.nan, 0.0
    if calibration is not None:
        scale = calibration.focal_baseline_px_m / float(np.linalg.norm(_normal_camera(ground, calibration)))
        doffs = float(calibration.doffs_px)
    floor = np.asarray(min_excess_px, dtype=np.float32)
    floor = np.full(d.shape, floor, np.float32) if floor.ndim == 0 else np.ascontiguousarray(floor)
    if floor.shape != d.shape:
        raise InvalidInputError(f"min_excess_px: expected one number or the disparity's shape {d.shape}, "
                                f"got {floor.shape}")
    if not np.isfinite(floor).all():
        raise InvalidInputError("min_excess_px: expected finite numbers of pixels")
    return raised_pixels_kernel(d, m, float(ground.a), float(ground.b), float(ground.c), doffs, scale,
                                float(min_height_m), bool(strict), floor)


def tilt_from_camera_vertical_deg(ground: GroundPlane, calibration: StereoCalibration) -> float:
    """Angle between the plane's normal and the camera's vertical (Y) axis, degrees.

    The camera's pitch and roll for a real ground (a few to some 30 degrees); near 90 for a
    wall facing the camera.
    """
    normal = _normal_camera(ground, calibration)
    return math.degrees(math.acos(min(1.0, abs(normal[1]) / np.linalg.norm(normal))))


__all__ = ["GroundPlane", "PlaneFitParameters", "fit_plane_points", "fit_ground_plane", "height_above_ground_m",
           "raised_pixels", "tilt_from_camera_vertical_deg"]
