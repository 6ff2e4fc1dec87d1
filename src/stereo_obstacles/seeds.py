"""Seeds of the growth: correspondences found by a full scanline search at chosen pixels.

The paper's seeds are edge pixels of the left image (Canny, or a Sobel magnitude
threshold), each matched along its scanline to its best similarity and kept when it is
distinctive: at least ``tau`` and better than the runner-up (outside ``d +- 1``) by
``margin``. Random pixels matched the same way and a user-supplied list of
correspondences are offered too, so that the paper's claim about edge seeds can be checked.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import cv2
import numpy as np

from stereo_obstacles._edge_cells_kernel import magnitude_and_cells, rows_and_columns, strongest_per_cell
from stereo_obstacles._similarity_kernel import _scan_best
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.quantiles import percentile
from stereo_obstacles.similarity import SimilarityInputs, similarity_at
from stereo_obstacles.thread_pool import run_in_threads

__all__ = ["DEFAULT_SEEDS", "EDGE_PERCENTILE", "SEED_SOURCES", "Seeds", "edge_pixels", "find_seeds",
           "match_pixels", "random_pixels", "user_seeds"]

logger = logging.getLogger(__name__)

SEED_SOURCES = ("canny", "sobel", "random")
"""Seed sources chosen by name (a user list is passed as points instead)."""

DEFAULT_SEEDS = "sobel"
"""Seed source of the matcher by default. The paper allows Canny or Sobel edges; thinned to one
per cell they pick nearly the same pixels, with the same bad-1 and density on the Middlebury,
Aloe and KITTI pairs (to 0.06 points), and the Sobel threshold skips Canny's own pass: about
1 ms less per Middlebury pair (``docs/matching.md``, session 15). Canny until session 14."""

EDGE_PERCENTILE = 80.0
"""Percentile of the non-zero Sobel gradient magnitudes used as the edge threshold (Canny: high one)."""


NOT_SCANNED = np.iinfo(np.int32).min
"""``scanned_hi`` of a pixel no scanline search visited: below every disparity, negative ones
included (a -1 would count the disparities from a negative ``d_min`` to -1 as scanned)."""


@dataclass(frozen=True)
class Seeds:
    """Seed correspondences: left pixel ``(x, y)`` with right pixel ``(x_right, y)``.

    Attributes
    ----------
    y, x, x_right : ndarray of int32, shape (N,)
    similarity : ndarray of float32, shape (N,)
    n_evaluated : int
        Similarities computed to find them (scanline searches).
    n_candidates : int
        Pixels searched before the distinctiveness test.
    scanned_hi : ndarray of int32, shape (H, W), optional
        Largest disparity the scanline search evaluated at each pixel (from ``d_min``),
        :data:`NOT_SCANNED` where there was no search; None when nothing was searched.
    """

    y: np.ndarray
    x: np.ndarray
    x_right: np.ndarray
    similarity: np.ndarray
    n_evaluated: int
    n_candidates: int
    scanned_hi: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = self.y.shape[0]
        for field in ("x", "x_right", "similarity"):
            if getattr(self, field).shape != (n,):
                raise InvalidInputError(f"{field}: expected shape ({n},), got {getattr(self, field).shape}")

    def __len__(self) -> int:
        return int(self.y.shape[0])


def _gradient_cells(grey: np.ndarray, spacing: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sobel gradient magnitude ``(H, W)`` of a grey image, and the largest magnitude and its flat
    pixel index per ``spacing x spacing`` cell (:func:`magnitude_and_cells`; one thread: two took
    longer on Teddy, 0.27 ms of work against the hand-over to the pool)."""
    gx = cv2.Sobel(grey, cv2.CV_32F, 1, 0, ksize=3)
    gy = cv2.Sobel(grey, cv2.CV_32F, 0, 1, ksize=3)
    h, w = grey.shape
    magnitude = np.empty((h, w), np.float32)
    cell_max = np.empty((-(-h // spacing), -(-w // spacing)), np.float32)
    cell_pos = np.empty(cell_max.shape, np.int64)
    magnitude_and_cells(gx, gy, spacing, magnitude, cell_max, cell_pos)
    return magnitude, cell_max, cell_pos


def edge_pixels(grey: np.ndarray, method: str = DEFAULT_SEEDS,
                spacing: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Rows and columns of the edge pixels of a grey image.

    Parameters
    ----------
    grey : ndarray of float32, shape (H, W)
    method : {"sobel", "canny"}
        ``"sobel"`` (:data:`DEFAULT_SEEDS`): every pixel whose Sobel magnitude reaches the
        :data:`EDGE_PERCENTILE` percentile of the non-zero magnitudes. ``"canny"``: Canny edges (L2
        gradient, that percentile as the high threshold, half of it as the low one; thinner).
    spacing : int
        Keep at most one edge pixel, the one of strongest gradient, per ``spacing x spacing``
        cell of the image (1: every edge pixel).

    Returns
    -------
    ys, xs : ndarray of int32
        Edge pixels in raster order. Empty for a flat image.
    """
    if int(spacing) != spacing or spacing < 1:
        raise InvalidInputError(f"spacing: expected an integer >= 1, got {spacing}")
    spacing = int(spacing)
    mag, cell_max, cell_pos = _gradient_cells(grey, spacing)
    textured = mag[mag > 1e-3 * max(float(cell_max.max()), 1e-12)]
    if textured.size == 0:
        return np.empty(0, np.int32), np.empty(0, np.int32)
    high = percentile(textured, EDGE_PERCENTILE)   # one partial sort: 8x faster than np.percentile on 170 k values
    if method == "canny":
        lo, hi = float(grey.min()), float(grey.max())
        scale = 255.0 / (hi - lo)
        image8 = np.clip((grey - lo) * scale, 0, 255).astype(np.uint8)
        edges = cv2.Canny(image8, 0.5 * high * scale, high * scale, L2gradient=True) > 0
    elif method == "sobel":
        if spacing > 1:  # a cell holds an edge pixel when its strongest pixel is one
            return rows_and_columns(np.sort(cell_pos[cell_max >= high]), grey.shape[1])
        edges = mag >= high
    else:
        raise InvalidInputError(f"method: expected 'canny' or 'sobel', got {method!r}")
    if spacing > 1:
        return strongest_per_cell(edges, mag, spacing)
    ys, xs = np.nonzero(edges)
    return ys.astype(np.int32), xs.astype(np.int32)


def random_pixels(shape: tuple[int, int], count: int, rng_seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """``count`` distinct random pixels of an image of ``shape`` (raster order)."""
    h, w = shape
    count = min(int(count), h * w)
    flat = np.sort(np.random.default_rng(rng_seed).choice(h * w, size=count, replace=False))
    return (flat // w).astype(np.int32), (flat % w).astype(np.int32)


def match_pixels(inputs: SimilarityInputs, ys: np.ndarray, xs: np.ndarray, *, d_min: int, d_max: int,
                 tau: float, margin: float, n_threads: int = 1) -> Seeds:
    """Match left pixels along their scanlines and keep the distinctive best matches.

    Parameters
    ----------
    inputs : SimilarityInputs
    ys, xs : ndarray of int32, shape (N,)
        Left pixels to match.
    d_min, d_max : int
        Disparity search range in pixels, inclusive.
    tau : float
        Minimum similarity of a seed.
    margin : float
        The best similarity must beat the runner-up outside ``d +- 1`` by this much.
    n_threads : int
        The pixels are searched in this many equal chunks, one thread each (same result).

    Returns
    -------
    Seeds
    """
    ys = np.ascontiguousarray(ys, np.int32)
    xs = np.ascontiguousarray(xs, np.int32)
    if ys.size == 0:
        empty = np.empty(0, np.int32)
        return Seeds(empty, empty, empty, np.empty(0, np.float32), 0, 0)
    if int(n_threads) != n_threads or n_threads < 1:
        raise InvalidInputError(f"n_threads: expected an integer >= 1, got {n_threads}")
    edges = np.linspace(0, ys.size, int(n_threads) + 1).astype(int)
    parts = run_in_threads(_scan_best, [(*inputs.kernel_args(), ys[lo:hi], xs[lo:hi], d_min, d_max, 1)
                                        for lo, hi in zip(edges[:-1], edges[1:])])
    best_d, best_c, second_c = (np.concatenate([p[k] for p in parts]) for k in range(3))
    n_eval = sum(p[3] for p in parts)
    keep = (best_d >= 0) & (best_c >= tau) & (best_c - second_c >= margin)
    scanned_hi = np.full(inputs.shape, NOT_SCANNED, np.int32)
    scanned_hi[ys, xs] = np.where(np.minimum(xs, d_max) >= d_min, np.minimum(xs, d_max), NOT_SCANNED)
    return Seeds(ys[keep], xs[keep], (xs[keep] - best_d[keep]).astype(np.int32), best_c[keep],
                 int(n_eval), int(ys.size), scanned_hi)


def user_seeds(inputs: SimilarityInputs, points: np.ndarray, *, d_min: int, d_max: int) -> Seeds:
    """Seeds from a user list of ``(x, y, d)`` rows (pixels, integer disparity).

    Points outside the image or the disparity range raise; points are kept whatever their
    similarity (the growth still applies ``tau`` to everything it adds).
    """
    p = np.asarray(points)
    if p.ndim != 2 or p.shape[1] != 3:
        raise InvalidInputError(f"seed_points: expected shape (N, 3) of (x, y, d), got {p.shape}")
    if p.size and not np.all(np.isfinite(p)):
        raise InvalidInputError("seed_points: contains NaN or infinite values")
    p = np.rint(p).astype(np.int64)
    x, y, d = p[:, 0], p[:, 1], p[:, 2]
    h, w = inputs.shape
    bad = (y < 0) | (y >= h) | (x < 0) | (x >= w) | (d < d_min) | (d > d_max) | (x - d < 0)
    if bad.any():
        i = int(np.argmax(bad))
        raise InvalidInputError(f"seed_points: row {i} (x={x[i]}, y={y[i]}, d={d[i]}) is outside the "
                                f"{w}x{h} image or the disparity range [{d_min}, {d_max}]")
    c = similarity_at(inputs, y, x, x - d)
    return Seeds(y.astype(np.int32), x.astype(np.int32), (x - d).astype(np.int32), c, len(c), len(c))


def find_seeds(inputs: SimilarityInputs, left_grey: np.ndarray, source: str, *, d_min: int, d_max: int,
               tau: float, margin: float, rng_seed: int = 0, random_fraction: float = 0.1,
               spacing: int = 1, n_threads: int = 1) -> Seeds:
    """Seeds from a named source: ``"canny"``, ``"sobel"`` or ``"random"``.

    Edge seeds keep at most one pixel per ``spacing x spacing`` cell (see :func:`edge_pixels`);
    ``"random"`` matches ``random_fraction / spacing`` of all pixels, chosen with ``rng_seed``
    (with the defaults, about as many pixels as the thinned edge pixels of the Middlebury pairs).
    The scanline searches run in ``n_threads`` threads (:func:`match_pixels`).
    """
    if source in ("canny", "sobel"):
        ys, xs = edge_pixels(left_grey, source, spacing)
    elif source == "random":
        ys, xs = random_pixels(left_grey.shape, round(random_fraction * left_grey.size / spacing), rng_seed)
    else:
        raise InvalidInputError(f"seeds: expected one of {list(SEED_SOURCES)} or points, got {source!r}")
    seeds = match_pixels(inputs, ys, xs, d_min=d_min, d_max=d_max, tau=tau, margin=margin, n_threads=n_threads)
    logger.debug("%s seeds: %d of %d pixels kept", source, len(seeds), seeds.n_candidates)
    return seeds
