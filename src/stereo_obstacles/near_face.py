"""The near face of an obstacle: how far away the part of it met first is.

An obstacle's distance is a low percentile (``percentile``, the 5th in the pipeline) of the
median depths of its 8x8-pixel patches, each first replaced by the median of the patch medians
in its neighbourhood (the obstacle's patches within ``neighbourhood_patches`` patches of it, 1 in
the pipeline: 3 x 3 patches). Taking patch medians keeps the percentile from following the noise
of single matches (a plain 10th percentile of pixel depths reads 1-2 % too near); their
neighbourhood medians keep it from following single patches: a patch of few noisy matches, or
of a nearer neighbour's pixels spread over the obstacle's outline by the matching (a box at
8.8 m, a tenth of whose pixels were such, read -5.5 % before, -2.0 % with them;
``docs/pipeline.md``, "Neighbourhood medians of the patches"). Patches holding fewer than
``min_patch_pixels`` of the obstacle's pixels are left out (all are used when none holds that
many): they are mostly a fringe of a pixel or two along the object's outline, matched at a
disparity borrowed from the window around them (a one-pixel column of sky beside a far pole read
7.5 px, the pole's own matches 6.9 and its truth 6.6).

A face slanted in depth (a wall seen obliquely, the top of a low box seen from above) spreads
its patches over a range of disparities, and the percentile lies behind its nearest part by
a part of that range (at the 10th percentile of the patch medians a tenth: 1.5 px on a wall
receding from 31 to 16 px of disparity, 5 % in distance; synthetic scene 114's wall of that kind
read +8.8 %, and at the pipeline's 5th percentile of neighbourhood medians +6.4 %). When one plane
``d = a x + b y + c`` fits the face's patch medians and spans a large part of its disparity
(:class:`SlantedFaceParameters`), the distance is read from the plane at the face's nearest
patch instead (if that is nearer): a plane through dozens of patches does not follow the noise
of one, which the nearest patch alone would (``docs/pipeline.md``, "Slanted faces"). The plane
is fitted to the patch medians themselves, not their neighbourhood medians. Only the
patches on the plane count for where it is read and for its span: extended to patches off it (a
piece of another face, a fattened edge), the plane reads what lies beyond the face (until
session 32 a wall 3.44 m away read -6.1 % so).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stereo_obstacles import quantiles
from stereo_obstacles._obstacles_kernel import neighbourhood_medians_kernel, patch_medians_kernel
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import check_integers, check_numbers, is_finite_real, is_whole_number
from stereo_obstacles.plane_fit import least_squares_plane, plane_at

DISTANCE_PATCH_PX = 8
"""Side of the square patches whose median depths the distance is taken over, pixels."""

MAX_NEIGHBOURHOOD_PATCHES = 100
"""Largest ``neighbourhood_patches`` accepted: 100 patches reach 800 pixels to either side, far
more than smoothing a near face needs (the kernel's grid grows with it)."""

PLANE_FIT_ROUNDS = 3
"""The plane is fitted this many times in all: first to every patch, then to the patches within
the tolerance of the previous plane."""


@dataclass(frozen=True)
class SlantedFaceParameters:
    """When an obstacle's distance is read from a plane through its patches.

    The plane is used when, over the patches that count for the distance: at least
    ``min_patches`` of them are there; after refitting, at least ``min_inlier_fraction`` of them
    lie within ``max(tolerance_px, tolerance_fraction * d)`` of the plane (``d``: the patch's
    disparity plus the calibration's ``doffs``, pixels); and the plane's values at the centres
    of the patches on it span at least ``min_span_fraction`` of the largest one. A span of 30 % is
    where the lag of the 10th percentile of the patch medians (with which the gate was chosen), a
    tenth of the span, reaches 3 % of the distance.

    Attributes
    ----------
    min_span_fraction : float
        Span of the plane's disparities over its patches on the plane, as a fraction of its
        nearest one.
    tolerance_px, tolerance_fraction : float
        A patch lies on the plane within the larger of these (pixels; fraction of its disparity).
    min_inlier_fraction : float
        Fraction of the patches that must lie on the plane.
    min_patches : int
        Patches the fit needs.
    """

    min_span_fraction: float = 0.3
    tolerance_px: float = 0.3
    tolerance_fraction: float = 0.03
    min_inlier_fraction: float = 0.92
    min_patches: int = 6

    def __post_init__(self) -> None:
        check_numbers(self, (("min_span_fraction", 0.0, 1.0), ("tolerance_px", 0.0, 100.0),
                             ("tolerance_fraction", 0.0, 1.0), ("min_inlier_fraction", 0.0, 1.0)))
        check_integers(self, (("min_patches", 3, 10 ** 6),))


def near_face_depth(xs: np.ndarray, ys: np.ndarray, z: np.ndarray, *, percentile: float,
                    min_patch_pixels: int = 1, neighbourhood_patches: int = 0,
                    focal_baseline_px_m: float | None = None,
                    slanted_face: SlantedFaceParameters | None = None) -> float:
    """Distance of an obstacle's near face, metres.

    Parameters
    ----------
    xs, ys : ndarray of int, shape (N,)
        Columns and rows of the obstacle's pixels (non-negative).
    z : ndarray of float, shape (N,)
        Their depths, metres (positive).
    percentile : float
        Percentile taken of the patches' median depths (of their neighbourhood medians, with
        ``neighbourhood_patches``), in [0, 100].
    min_patch_pixels : int
        Patches with fewer of the pixels do not count (unless none has that many).
    neighbourhood_patches : int
        The percentile is taken over each counting patch's median of the counting patches'
        medians within this many patches of it in column and in row (itself included); 0 takes
        the patch medians themselves.
    focal_baseline_px_m : float, optional
        ``f B`` of the calibration (pixels x metres): ``f B / z`` is the disparity plus
        ``doffs``. Needed with ``slanted_face``.
    slanted_face : SlantedFaceParameters, optional
        Read a slanted face's distance from its plane; ``None`` takes the percentile alone.

    Returns
    -------
    float
        The ``percentile`` of the patches' (neighbourhood) medians, or the plane's nearer depth
        at the nearest patch centre on the plane of a slanted face.

    Raises
    ------
    InvalidInputError
        Arrays of different lengths or none, negative or non-integer coordinates, depths that
        are not finite and positive, a percentile outside [0, 100], ``min_patch_pixels`` below
        1, ``neighbourhood_patches`` not an integer in [0, 100], or ``slanted_face`` without a
        positive ``focal_baseline_px_m``.

    Examples
    --------
    >>> import numpy as np
    >>> ys, xs = np.mgrid[0:40, 0:120]
    >>> d = 31.0 - 0.1 * xs                      # a wall receding from 31 to 19 px of disparity
    >>> z = 66.48 / d                            # depths for f B = 66.48 px m
    >>> round(near_face_depth(xs.ravel(), ys.ravel(), z.ravel(), percentile=10.0), 3)
    2.227
    >>> round(near_face_depth(xs.ravel(), ys.ravel(), z.ravel(), percentile=10.0, focal_baseline_px_m=66.48,
    ...                       slanted_face=SlantedFaceParameters()), 3)
    2.169
    """
    xs, ys, z = _checked(xs, ys, z, percentile, min_patch_pixels, neighbourhood_patches, focal_baseline_px_m,
                         slanted_face)
    medians, centre_x, centre_y, counts, columns, rows = patch_medians_kernel(xs, ys, z, DISTANCE_PATCH_PX)
    full = counts >= min_patch_pixels
    if full.any():
        medians, centre_x, centre_y = medians[full], centre_x[full], centre_y[full]
        columns, rows = columns[full], rows[full]
    percentile_depths = medians
    if neighbourhood_patches > 0:
        percentile_depths = neighbourhood_medians_kernel(medians, columns, rows, int(neighbourhood_patches))
    depth = quantiles.percentile(percentile_depths, percentile)
    if slanted_face is None:
        return depth
    nearest_px = slanted_face_disparity(centre_x, centre_y, focal_baseline_px_m / medians, slanted_face)
    return depth if nearest_px is None else min(depth, focal_baseline_px_m / nearest_px)


def _checked(xs, ys, z, percentile, min_patch_pixels, neighbourhood_patches, focal_baseline_px_m, slanted_face
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The arguments of :func:`near_face_depth` as the kernel takes them (int64, int64, float64
    arrays), or :class:`~stereo_obstacles.errors.InvalidInputError` naming the first wrong one."""
    xs, ys, z = np.asarray(xs), np.asarray(ys), np.asarray(z)
    if xs.ndim != 1 or xs.size == 0 or ys.shape != xs.shape or z.shape != xs.shape:
        raise InvalidInputError(f"xs, ys and z must be 1-D arrays of one length, at least 1, got shapes {xs.shape}, "
                                f"{ys.shape} and {z.shape}")
    for name, coordinates in (("xs", xs), ("ys", ys)):
        if not np.issubdtype(coordinates.dtype, np.integer) or coordinates.min() < 0:
            raise InvalidInputError(f"{name} must be non-negative integer pixel coordinates, got {coordinates.dtype} "
                                    f"from {coordinates.min()}")
    if not (np.issubdtype(z.dtype, np.floating) or np.issubdtype(z.dtype, np.integer)):
        raise InvalidInputError(f"z must hold real depths (metres), got {z.dtype}")
    bad = ~(np.isfinite(z) & (z > 0))
    if bad.any():
        raise InvalidInputError(f"z must hold finite depths > 0 (metres), got {float(z[bad][0])} at index "
                                f"{int(np.flatnonzero(bad)[0])}")
    if not (is_finite_real(percentile) and 0 <= percentile <= 100):
        raise InvalidInputError(f"percentile must be in [0, 100], got {percentile!r}")
    if not is_whole_number(min_patch_pixels) or min_patch_pixels < 1:
        raise InvalidInputError(f"min_patch_pixels must be an integer >= 1, got {min_patch_pixels!r}")
    if not is_whole_number(neighbourhood_patches) or not 0 <= neighbourhood_patches <= MAX_NEIGHBOURHOOD_PATCHES:
        raise InvalidInputError(f"neighbourhood_patches must be an integer in [0, {MAX_NEIGHBOURHOOD_PATCHES}], got "
                                f"{neighbourhood_patches!r}")
    if slanted_face is not None:
        if not isinstance(slanted_face, SlantedFaceParameters):
            raise InvalidInputError(f"slanted_face must be SlantedFaceParameters or None, got "
                                    f"{type(slanted_face).__name__}")
        if not (is_finite_real(focal_baseline_px_m) and focal_baseline_px_m > 0):
            raise InvalidInputError(f"focal_baseline_px_m must be a finite number > 0 with slanted_face, got "
                                    f"{focal_baseline_px_m!r}")
    return xs.astype(np.int64, copy=False), ys.astype(np.int64, copy=False), z.astype(np.float64, copy=False)


def slanted_face_disparity(xs: np.ndarray, ys: np.ndarray, ds: np.ndarray,
                           params: SlantedFaceParameters) -> float | None:
    """The largest value (pixels) of the plane through the disparities ``ds`` (``float (N,)``,
    pixels, plus ``doffs``) at the patch centres ``xs, ys`` (``float (N,)``, pixels) that lie on
    it, or None when the patches are not a slanted face by ``params``: too few, off one plane,
    or spanning too little disparity on it."""
    on_plane = np.ones(len(ds), dtype=bool)
    tolerance = np.maximum(params.tolerance_px, params.tolerance_fraction * ds)
    for _ in range(PLANE_FIT_ROUNDS):
        plane = _face_plane(xs[on_plane], ys[on_plane], ds[on_plane])
        if plane is None:
            return None
        fitted = plane_at(plane, xs, ys)
        on_plane = np.abs(ds - fitted) <= tolerance
        if np.count_nonzero(on_plane) < params.min_patches:
            return None
    on_face = fitted[on_plane]
    nearest = float(on_face.max())
    if (on_plane.mean() < params.min_inlier_fraction or nearest <= 0
            or nearest - on_face.min() < params.min_span_fraction * nearest):
        return None
    return nearest


def _face_plane(xs: np.ndarray, ys: np.ndarray, ds: np.ndarray) -> tuple[float, float, float] | None:
    """:func:`~stereo_obstacles.plane_fit.least_squares_plane` of the points, or, when they lie in
    one row (one column) of patches, the least-squares line along it, level across: a face one
    patch tall is measured as one two patches tall is (``(a, b, c)`` of ``d = a x + b y + c``)."""
    plane = least_squares_plane(xs, ys, ds)
    if plane is not None or len(ds) < 2:
        return plane
    for along, other in ((xs, ys), (ys, xs)):
        if np.ptp(other) == 0 and np.ptp(along) > 0:
            centred = along - along.mean()
            slope = float((centred * (ds - ds.mean())).sum() / (centred * centred).sum())
            offset = float(ds.mean() - slope * along.mean())
            return (slope, 0.0, offset) if along is xs else (0.0, slope, offset)
    return None


__all__ = ["DISTANCE_PATCH_PX", "MAX_NEIGHBOURHOOD_PATCHES", "SlantedFaceParameters", "near_face_depth",
           "slanted_face_disparity"]
