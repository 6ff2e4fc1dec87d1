"""Window similarity of a left and a right pixel: NCC or Moravec's MNCC on a 5 x 5 window.

For a left pixel ``(x, y)`` and a right pixel ``(x', y)`` with windows ``L`` and ``R``
(25 grey values each):

* NCC  = cov(L, R) / (std L * std R)
* MNCC = 2 cov(L, R) / (var L + var R)   (Moravec; also penalises a contrast difference)

Window means and variances are computed once per image with box filters
(:func:`prepare_similarity`); the compiled kernels then only form the 25 products of a
point. A window whose standard deviation is below ``min_std`` grey levels is too flat to
correlate: every point touching it gets the similarity :data:`UNDEFINED` (-1), so it can
never pass a positive threshold. Images are padded by reflection (``BORDER_REFLECT_101``)
so that border pixels have full windows.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from stereo_obstacles._similarity_kernel import (KIND_MNCC, KIND_NCC, RADIUS, UNDEFINED, _similarity_points,
                                                 _window_stats_kernel)
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.image_pairs import check_same_size
from stereo_obstacles.thread_pool import run_in_threads

logger = logging.getLogger(__name__)

__all__ = ["KINDS", "RADIUS", "UNDEFINED", "SimilarityInputs", "grey_pair", "prepare_similarity", "similarity_at",
           "to_grey"]

KINDS = {"ncc": KIND_NCC, "mncc": KIND_MNCC}
"""Similarity names accepted by :func:`prepare_similarity` and their kernel codes."""

_RGB_WEIGHTS = np.array([0.299, 0.587, 0.114], np.float32)


def _numeric_image(image, name: str) -> np.ndarray:
    """``image`` as an array of integers or floats (not booleans), or :class:`InvalidInputError`."""
    a = np.asarray(image)
    if a.dtype == bool or not (np.issubdtype(a.dtype, np.integer) or np.issubdtype(a.dtype, np.floating)):
        raise InvalidInputError(f"{name}: expected an integer or float image, got dtype {a.dtype}")
    return a


def to_grey(image: np.ndarray, name: str = "image") -> np.ndarray:
    """Grey float32 copy of an image, without rescaling intensities.

    Parameters
    ----------
    image : ndarray, shape (H, W) or (H, W, 3)
        Grey or RGB image, any integer or float dtype (RGB weighted 0.299, 0.587, 0.114).
    name : str
        Argument name used in error messages.

    Returns
    -------
    ndarray of float32, shape (H, W)
        Intensities in the input's own units.

    Raises
    ------
    InvalidInputError
        Wrong number of dimensions or channels, non-numeric dtype or non-finite values.
    """
    a = _numeric_image(image, name)
    if a.ndim == 3 and a.shape[2] == 3:
        grey = a.astype(np.float32) @ _RGB_WEIGHTS
    elif a.ndim == 2:
        grey = a.astype(np.float32)
    else:
        raise InvalidInputError(f"{name}: expected shape (H, W) or (H, W, 3), got {a.shape}")
    if not np.isfinite(grey).all():
        raise InvalidInputError(f"{name}: contains NaN or infinite values")
    return np.ascontiguousarray(grey)


def grey_pair(left: np.ndarray, right: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`to_grey` of both images of a pair, in grey levels of 0..255 when the pair is of
    0..1 floats.

    A pair of float images whose values all lie in [0, 1] is taken as 0..1 intensities and both
    are scaled by 255, so that thresholds in grey levels (the matcher's ``min_std``, the seeds'
    edge thresholds) mean what they mean for 8-bit images: left as they were, no window was
    textured enough and nothing matched. The pair is decided on as a whole, so that both images
    stay in one unit.
    """
    greys = to_grey(left, "left"), to_grey(right, "right")
    images = [np.asarray(image) for image in (left, right)]
    if all(np.issubdtype(a.dtype, np.floating) and a.size and a.min() >= 0.0 and a.max() <= 1.0 for a in images):
        logger.info("float images of 0..1: matched as grey levels of 0..255")
        for grey in greys:
            grey *= np.float32(255.0)
    return greys


@dataclass(frozen=True)
class SimilarityInputs:
    """Everything the compiled kernels read to score a point ``(y, x, x')``.

    Attributes
    ----------
    left_pad, right_pad : ndarray of float64, shape (H + 4, W + 4)
        Grey images minus their own mean, rounded to float32 and padded by reflection by
        :data:`RADIUS`. Held in float64 (the values of the float32 rounding, exactly): the
        kernels form the window products in float64, and reading them without a conversion
        made the growth about 7 % faster with the same results.
    mean_l, mean_r : ndarray of float32, shape (H, W)
        Window means of the padded images (same offset as ``left_pad``/``right_pad``).
    norm_l, norm_r : ndarray of float32, shape (H, W)
        NCC: ``1 / std`` of the window; MNCC: its variance. 0 where ``std < min_std``.
    kind : int
        Kernel code of the similarity (see :data:`KINDS`).
    """

    left_pad: np.ndarray
    right_pad: np.ndarray
    mean_l: np.ndarray
    norm_l: np.ndarray
    mean_r: np.ndarray
    norm_r: np.ndarray
    kind: int

    def __post_init__(self) -> None:
        h, w = self.mean_l.shape
        for field in ("left_pad", "right_pad"):
            if getattr(self, field).shape != (h + 2 * RADIUS, w + 2 * RADIUS):
                raise InvalidInputError(f"{field}: expected shape {(h + 2 * RADIUS, w + 2 * RADIUS)}")
        for field in ("norm_l", "mean_r", "norm_r"):
            if getattr(self, field).shape != (h, w):
                raise InvalidInputError(f"{field}: expected shape {(h, w)}")
        if self.kind not in KINDS.values():
            raise InvalidInputError(f"kind: expected one of {sorted(KINDS.values())}, got {self.kind}")

    @property
    def shape(self) -> tuple[int, int]:
        """Image shape ``(H, W)``."""
        return self.mean_l.shape

    def rows(self, lo: int, hi: int) -> "SimilarityInputs":
        """The prepared images of image rows ``[lo, hi)``, as views (the padded images keep the
        :data:`RADIUS` border rows around them, so windows centred on those rows read the same
        pixels as in the whole image)."""
        pad = 2 * RADIUS
        return SimilarityInputs(self.left_pad[lo:hi + pad], self.right_pad[lo:hi + pad], self.mean_l[lo:hi],
                                self.norm_l[lo:hi], self.mean_r[lo:hi], self.norm_r[lo:hi], self.kind)

    def kernel_args(self) -> tuple:
        """The arrays and code in the order the kernels take them."""
        return (self.left_pad, self.right_pad, self.mean_l, self.norm_l, self.mean_r, self.norm_r,
                self.kind)


def _window_stats(grey: np.ndarray, kind: int, min_std: float) -> tuple[np.ndarray, ...]:
    # one compiled pass (padding, window sums, norms): OpenCV's box filters and border copy
    # gave the same float32 statistics in 1.8x the time (KITTI 000005: 7.7 -> 3.4 ms an image)
    # a zero variance is flat even with min_std 0
    if grey.dtype not in (np.float32, np.float64):  # exact, and one compiled kernel for the rest
        grey = grey.astype(np.float64)
    return _window_stats_kernel(grey, float(grey.mean()), kind, max(min_std * min_std, 1e-12))


def prepare_similarity(left_grey: np.ndarray, right_grey: np.ndarray, *, kind: str = "ncc",
                       min_std: float = 1.0, n_threads: int = 1) -> SimilarityInputs:
    """Pad both grey images and precompute their window statistics.

    Parameters
    ----------
    left_grey, right_grey : ndarray of float32, shape (H, W)
        Grey images (see :func:`to_grey`), same shape, at least 5 x 5.
    kind : {"ncc", "mncc"}
        The similarity.
    min_std : float
        Windows with a standard deviation below this (grey levels) are flat: points
        touching them score :data:`UNDEFINED`.
    n_threads : int
        2 (or more) prepares the two images in two threads; 1 one after the other. Same result.

    Returns
    -------
    SimilarityInputs
    """
    if kind not in KINDS:
        raise InvalidInputError(f"similarity: expected one of {sorted(KINDS)}, got {kind!r}")
    if not min_std >= 0.0:
        raise InvalidInputError(f"min_std: expected >= 0, got {min_std}")
    if int(n_threads) != n_threads or n_threads < 1:
        raise InvalidInputError(f"n_threads: expected an integer >= 1, got {n_threads}")
    left_grey, right_grey = _numeric_image(left_grey, "left_grey"), _numeric_image(right_grey, "right_grey")
    for name, grey in (("left_grey", left_grey), ("right_grey", right_grey)):
        if grey.ndim != 2 or grey.size == 0:
            raise InvalidInputError(f"{name}: expected a non-empty 2-D grey image, got shape {grey.shape}")
    check_same_size(left_grey, right_grey)
    code = KINDS[kind]
    images = [(left_grey, code, min_std), (right_grey, code, min_std)]
    (lp, ml, nl), (rp, mr, nr) = (run_in_threads(_window_stats, images) if n_threads > 1
                                  else [_window_stats(*a) for a in images])
    return SimilarityInputs(lp, rp, ml, nl, mr, nr, code)


def similarity_at(inputs: SimilarityInputs, y: np.ndarray, x: np.ndarray, x_right: np.ndarray) -> np.ndarray:
    """Similarity of left pixels ``(x, y)`` with right pixels ``(x_right, y)``.

    Parameters
    ----------
    inputs : SimilarityInputs
    y, x, x_right : array_like of int, same shape
        Row, left column and right column of each point, inside the image.

    Returns
    -------
    ndarray of float32, same shape as ``y``
        Similarity in [-1, 1]; :data:`UNDEFINED` where a window is flat.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> img = rng.uniform(0, 255, (20, 30)).astype(np.float32)
    >>> s = prepare_similarity(img, img)
    >>> round(float(similarity_at(s, np.array([10]), np.array([12]), np.array([12]))[0]), 6)
    1.0
    """
    y, x, x_right = (np.asarray(v, dtype=np.int64) for v in np.broadcast_arrays(y, x, x_right))
    h, w = inputs.shape
    if y.size and (y.min() < 0 or y.max() >= h or min(x.min(), x_right.min()) < 0
                   or max(x.max(), x_right.max()) >= w):
        raise InvalidInputError(f"points: expected 0 <= y < {h} and 0 <= x, x_right < {w}")
    out = np.empty(y.size, np.float32)
    _similarity_points(*inputs.kernel_args(), y.ravel(), x.ravel(), x_right.ravel(), out)
    return out.reshape(y.shape)
