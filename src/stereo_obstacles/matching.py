"""Semi-dense stereo matching by Growing Correspondence Seeds (GCS): the public entry point.

Stages (each timed): *prepare* (grey conversion, window statistics), *seeds* (edge or
random pixels matched along their scanline, or a user list), *growth* (best-first growth
of the candidate table, :mod:`stereo_obstacles.growing`), *final* (confidently stable
matching, :mod:`stereo_obstacles.stable_matching`; skipped by the greedy variant) and
*subpixel* (:mod:`stereo_obstacles.subpixel`), then two checks that are not part of the
published method: the shifted-window check (:mod:`stereo_obstacles.shifted_windows`) and
speckle removal (:mod:`stereo_obstacles.speckles`). See ``docs/matching.md``.
"""

from __future__ import annotations

import inspect
import logging
import math
import time
from dataclasses import asdict, dataclass

import numpy as np

from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import is_finite_real
from stereo_obstacles.image_pairs import check_same_size
from stereo_obstacles.banded import match_bands
from stereo_obstacles.growing import MARGIN_REFERENCES
from stereo_obstacles.match_memory import check_matching_size
from stereo_obstacles.seeds import DEFAULT_SEEDS, NOT_SCANNED, SEED_SOURCES, find_seeds, user_seeds
from stereo_obstacles.speckles import speckle_mask
from stereo_obstacles.similarity import KINDS, RADIUS, grey_pair, prepare_similarity

__all__ = ["BANDS", "DEFAULT_MAX_DISPARITY_FRACTION", "MIN_SIZE", "SEED_SPACING", "SPECKLE_RANGE", "SPECKLE_SIZE",
           "VARIANTS", "MatchResult", "MatchStats", "disparity_range", "match", "warm_up"]

logger = logging.getLogger(__name__)

VARIANTS = ("stable", "greedy")
"""``"stable"``: published GCS with the final stable matching; ``"greedy"``: fast variant."""

MIN_SIZE = 2 * RADIUS + 1
"""Smallest accepted image side in pixels (one correlation window)."""

SEED_SPACING = 8
"""Default side in pixels of the cells that keep one edge seed pixel each (see ``docs/matching.md``)."""

DEFAULT_MAX_DISPARITY_FRACTION = 1.0 / 3.0
"""Without ``max_disparity``, disparities up to this fraction of the image width are searched."""

BANDS = 2
"""Default number of row bands grown in parallel threads (``docs/matching.md``, "Both cores")."""

SPECKLE_SIZE = 200
"""Default largest region of matches (pixels) removed as a speckle (``docs/matching.md``, "Speckle removal")."""

SPECKLE_RANGE = 1.0
"""Default largest disparity step (pixels) between neighbours of one speckle region."""


@dataclass(frozen=True)
class MatchStats:
    """Statistics of one :func:`match` call.

    Attributes
    ----------
    n_seeds : int
        Seeds that entered the growth (similarity >= tau).
    n_seed_pixels : int
        Pixels searched along their scanline to find seeds.
    n_candidates : int
        Size of the candidate table after growth.
    n_visited : int
        Distinct disparity-space points whose similarity was computed: scanline searches
        of the seeds plus the points of growth and subpixel refinement that no seed search
        had evaluated.
    n_memo_overflow : int
        Points computed at a pixel whose memo was full.
    visited_fraction_full : float
        ``n_visited / (W * W * H)``.
    visited_fraction_range : float
        ``n_visited / (W * H * (d_max - d_min + 1))``.
    density : float
        Fraction of all the image's pixels with a disparity (``evaluate`` reports density over
        the non-occluded pixels with ground truth instead, which is higher).
    d_min, d_max : int
        Disparity range used, pixels.
    prepare_seconds, seeds_seconds, growth_seconds, final_seconds, subpixel_seconds : float
        Wall time of each stage.
    match_seconds : float
        ``seeds + growth + final + edge_check + speckle`` (the matching proper, as in the benchmark
        targets).
    total_seconds : float
        Every stage.
    n_edge_checked, n_edge_rejected : int
        Matches next to a disparity jump that the shifted-window check compared, and rejected
        (0 without ``shifted_windows``).
    edge_check_seconds : float
        Wall time the shifted-window check adds after the final matching: from the end of the
        slowest band's final matching to the end of the check's last strip of rows (strips a band
        checks while another still grows cost no wall time; :mod:`stereo_obstacles.banded`).
        0 without the check.
    n_speckle_removed : int
        Matches removed as speckles (0 with ``speckle_size=0``).
    speckle_seconds : float
        Wall time of the speckle removal.
    """

    n_seeds: int
    n_seed_pixels: int
    n_candidates: int
    n_visited: int
    n_memo_overflow: int
    visited_fraction_full: float
    visited_fraction_range: float
    density: float
    d_min: int
    d_max: int
    prepare_seconds: float
    seeds_seconds: float
    growth_seconds: float
    final_seconds: float
    subpixel_seconds: float
    match_seconds: float
    total_seconds: float
    n_edge_checked: int = 0
    n_edge_rejected: int = 0
    edge_check_seconds: float = 0.0
    n_speckle_removed: int = 0
    speckle_seconds: float = 0.0

    def __post_init__(self) -> None:
        if not 0.0 <= self.density <= 1.0:
            raise InvalidInputError(f"density: expected in [0, 1], got {self.density}")

    def to_dict(self) -> dict:
        """The statistics as a JSON-ready dict."""
        return asdict(self)


@dataclass(frozen=True)
class MatchResult:
    """Output of :func:`match`.

    Attributes
    ----------
    disparity : ndarray of float32, shape (H, W)
        Left disparity in pixels (subpixel), NaN where unmatched: left ``(x, y)`` matches
        right ``(x - d, y)``.
    similarity : ndarray of float32, shape (H, W)
        Similarity of each match at its integer disparity, NaN where unmatched.
    stats : MatchStats
    """

    disparity: np.ndarray
    similarity: np.ndarray
    stats: MatchStats

    def __post_init__(self) -> None:
        if self.disparity.shape != self.similarity.shape or self.disparity.ndim != 2:
            raise InvalidInputError(f"disparity, similarity: expected one (H, W) shape, got "
                                    f"{self.disparity.shape} and {self.similarity.shape}")


def _check_options(tau, mu, max_candidates, final_margin, similarity, variant, min_disparity,
                   max_disparity, margin_reference, seeds, seed_points, seed_spacing, rng_seed, bands,
                   speckle_size, speckle_range) -> None:
    numbers = {"tau": tau, "mu": mu, "max_candidates": max_candidates, "final_margin": final_margin,
               "min_disparity": min_disparity, "seed_spacing": seed_spacing, "rng_seed": rng_seed, "bands": bands}
    if max_disparity is not None:
        numbers["max_disparity"] = max_disparity
    for name, value in numbers.items():          # a string or NaN failed in the comparisons below with TypeError
        if not is_finite_real(value):
            raise InvalidInputError(f"{name}: expected a finite number, got {value!r}")
    if not 0.0 < tau < 1.0:
        raise InvalidInputError(f"tau: expected 0 < tau < 1, got {tau}")
    if not mu >= 0.0:
        raise InvalidInputError(f"mu: expected >= 0, got {mu}")
    if int(max_candidates) != max_candidates or max_candidates < 1:
        raise InvalidInputError(f"max_candidates: expected an integer >= 1, got {max_candidates}")
    if not final_margin >= 0.0:
        raise InvalidInputError(f"final_margin: expected >= 0, got {final_margin}")
    if similarity not in KINDS:
        raise InvalidInputError(f"similarity: expected one of {sorted(KINDS)}, got {similarity!r}")
    if variant not in VARIANTS:
        raise InvalidInputError(f"variant: expected one of {list(VARIANTS)}, got {variant!r}")
    if margin_reference not in MARGIN_REFERENCES:
        raise InvalidInputError(f"margin_reference: expected one of {list(MARGIN_REFERENCES)}, "
                                f"got {margin_reference!r}")
    if int(min_disparity) != min_disparity or min_disparity < 0:
        raise InvalidInputError(f"min_disparity: expected an integer >= 0, got {min_disparity}")
    if max_disparity is not None and (int(max_disparity) != max_disparity or max_disparity < min_disparity):
        raise InvalidInputError(f"max_disparity: expected an integer >= min_disparity ({min_disparity}), "
                                f"got {max_disparity}")
    if int(seed_spacing) != seed_spacing or seed_spacing < 1:
        raise InvalidInputError(f"seed_spacing: expected an integer >= 1, got {seed_spacing}")
    if seed_points is None and seeds not in SEED_SOURCES:
        raise InvalidInputError(f"seeds: expected one of {list(SEED_SOURCES)}, got {seeds!r}")
    if int(rng_seed) != rng_seed or rng_seed < 0:
        raise InvalidInputError(f"rng_seed: expected an integer >= 0, got {rng_seed}")
    if int(bands) != bands or bands < 1:
        raise InvalidInputError(f"bands: expected an integer >= 1, got {bands}")
    whole = isinstance(speckle_size, (int, np.integer)) or (is_finite_real(speckle_size)
                                                           and float(speckle_size).is_integer())
    if isinstance(speckle_size, (bool, np.bool_)) or not whole or speckle_size < 0:
        raise InvalidInputError(f"speckle_size: expected an integer >= 0, got {speckle_size!r}")
    if not (is_finite_real(speckle_range) and speckle_range >= 0):
        raise InvalidInputError(f"speckle_range: expected a finite number >= 0, got {speckle_range!r}")


LOW_DENSITY = 0.01
"""Below this fraction of matched pixels the result is flagged with a warning."""


def _warn_if_doubtful(density: float, n_seed_pixels: int, n_seeds: int, zero_fraction: float, d_min: int,
                      tau: float, user_seeds: bool) -> None:
    """Log a warning when the result is empty, very sparse, or all at disparity 0."""
    if density == 0.0:
        if n_seed_pixels == 0 and not user_seeds:
            reason = "the left image has no edges to start from (textureless)"
        elif n_seeds == 0:
            reason = (f"no seed reached the similarity threshold tau={tau} (textureless, unrelated or swapped "
                      f"images?)")
        else:
            reason = "no candidate survived (textureless, unrelated or swapped images?)"
        logger.warning("no match: %s; the disparity map is empty (density 0)", reason)
    elif density < LOW_DENSITY:
        logger.warning("only %.2f %% of the pixels matched: weak texture, unrelated or swapped images?",
                       100 * density)
    if density > 0 and d_min == 0 and zero_fraction > 0.9:
        logger.warning("%.0f %% of the matches are at disparity 0: are the left and right images the same?",
                       100 * zero_fraction)


CUT_OFF_FRACTION = 0.002
"""A warning when more than this share of the matches lie at the largest disparity searched:
0.003 % at most on the shared pairs with the default range, 1.6 % on KITTI and 5.7 % on
OpenCV's aloe with ``max_disparity=64``."""


def warn_if_range_cut_off(disparity: np.ndarray, d_max: int, limit_m: float | None = None, *,
                          default_limit: bool = False) -> float:
    """Warn when many matches of ``disparity`` (pixels, NaN unmatched) lie within half a pixel of
    ``d_max``, the largest disparity searched: surfaces nearer than that were matched at the limit
    and read farther than they are. Returns their share of the matches.

    ``limit_m``: the depth ``d_max`` stands for (metres), named in the warning when given.
    ``default_limit``: ``d_max`` is the default (a third of the width), not a maximum the user gave.
    """
    with np.errstate(invalid="ignore"):
        n_at_limit = int(np.count_nonzero((disparity >= d_max - 0.5) & (disparity < np.inf)))   # NaN: false
    if n_at_limit == 0:                                                     # the usual case
        return 0.0
    share = n_at_limit / int(np.count_nonzero(np.isfinite(disparity)))
    if share > CUT_OFF_FRACTION:
        than = f" than {limit_m:.2f} m" if limit_m is not None else " than that"
        if default_limit:
            advice = "the default limit is a third of the image width: give a larger --max-disparity"
        elif d_max < disparity_range(disparity.shape[-1])[1]:            # the default would search further
            advice = "raise the maximum disparity (--max-disparity) or leave it unset"
        else:
            advice = "raise the maximum disparity (--max-disparity)"
        logger.warning("%.1f %% of the matches (%d px) lie at the largest disparity searched, %d px: surfaces "
                       "nearer%s are cut off there and read farther than they are; %s", 100 * share, n_at_limit,
                       d_max, than, advice)
    return share


def disparity_range(width: int, min_disparity: int = 0, max_disparity: int | None = None) -> tuple[int, int]:
    """The inclusive disparity range ``(d_min, d_max)`` in pixels :func:`match` searches in an image
    ``width`` pixels wide: up to ``max_disparity``, or a third of the width without it, and at most
    ``width - 1``.

    Examples
    --------
    >>> disparity_range(640), disparity_range(640, 2, 64), disparity_range(40, 0, 100)
    ((0, 213), (2, 64), (0, 39))
    """
    d_min = int(min_disparity)
    if max_disparity is not None and (not math.isfinite(max_disparity) or max_disparity != int(max_disparity)
                                      or max_disparity < max(d_min, 1)):
        raise InvalidInputError(f"max_disparity: expected an integer >= {max(d_min, 1)}, got {max_disparity}")
    d_max = (int(max_disparity) if max_disparity is not None
             else max(d_min, round(width * DEFAULT_MAX_DISPARITY_FRACTION)))
    d_max = min(d_max, width - 1)
    if d_min > d_max:
        raise InvalidInputError(f"min_disparity: expected < image width {width}, got {d_min}")
    return d_min, d_max


def check_match_options(**options) -> None:
    """Raise :class:`InvalidInputError` when ``options`` (keyword arguments of :func:`match`, the
    others at their defaults) are not ones it takes, or out of their ranges: as :func:`match`
    would, before any image is read (for an options object made long before the images come)."""
    parameters = inspect.signature(match).parameters
    unknown = sorted(set(options) - (set(parameters) - {"left", "right"}))
    if unknown:
        raise InvalidInputError(f"not options of the matcher: {', '.join(unknown)}")
    _check_options(**{name: options.get(name, parameters[name].default)
                      for name in inspect.signature(_check_options).parameters})


def match(left: np.ndarray, right: np.ndarray, *, seeds: str = DEFAULT_SEEDS, max_disparity: int | None = None,
          min_disparity: int = 0, tau: float = 0.55, mu: float = 0.05, max_candidates: int = 4,
          final_margin: float = 0.1, similarity: str = "ncc", variant: str = "stable", rng_seed: int = 0,
          seed_points: np.ndarray | None = None, margin_reference: str = "max", min_std: float = 1.0,
          seed_margin: float = 0.1, seed_spacing: int = SEED_SPACING, bands: int = BANDS,
          shifted_windows: bool = True, speckle_size: int = SPECKLE_SIZE,
          speckle_range: float = SPECKLE_RANGE) -> MatchResult:
    """Match a rectified stereo pair by Growing Correspondence Seeds.

    Parameters
    ----------
    left, right : ndarray, shape (H, W) or (H, W, 3)
        Rectified grey or RGB images, any integer or float dtype, same shape, at least 5 x 5.
    seeds : {"sobel", "canny", "random"}
        Where seeds come from (ignored when ``seed_points`` is given): edge pixels of the left
        image by a Sobel magnitude threshold (default) or Canny, or random pixels.
    max_disparity : int, optional
        Largest disparity in pixels. Default: a third of the width (the growth itself needs
        no range; the bound limits seed searches and admissible points).
    min_disparity : int
        Smallest disparity in pixels (>= 0).
    tau : float
        Similarity threshold of a candidate, in (0, 1).
    mu : float
        Growth margin: a point joins when within ``mu`` of the best candidate so far at its
        pixels.
    max_candidates : int
        Cap ``K`` of candidates per pixel; keeps weak texture from exploding. The default 4
        (the published method: 10) gave the same accuracy on the Middlebury pairs in 0.7x the
        match time (``docs/matching.md``, "Candidates per pixel").
    final_margin : float
        Relative confidence margin of the final stable matching.
    similarity : {"ncc", "mncc"}
        Window similarity (5 x 5).
    variant : {"stable", "greedy"}
        ``"greedy"`` is faster and denser but makes more errors.
    rng_seed : int
        Seed of the random generator for ``seeds="random"``.
    seed_points : ndarray, shape (N, 3), optional
        User seeds as ``(x, y, d)`` rows (pixels).
    margin_reference : {"max", "min"}
        Combination of the left and right per-pixel bests in the growth test.
    min_std : float
        Windows flatter than this standard deviation (grey levels) never match.
    seed_margin : float
        A scanline seed must beat its runner-up (outside ``d +- 1``) by this similarity.
    seed_spacing : int
        At most one edge seed pixel (the strongest gradient) per ``seed_spacing`` square cell;
        random seeds are thinned by the same factor. 1 searches every edge pixel (the paper);
        the default 8 searches ~14x fewer with the same accuracy (``docs/matching.md``).
    bands : int
        Horizontal row bands grown, matched and refined in parallel threads
        (:mod:`stereo_obstacles.banded`); 1 is the published single-queue growth. The default 2
        gave the same bad-1 and density to 0.01 points on the Middlebury pairs and 1.4-1.8x less
        match time when the second core was free (``docs/matching.md``).
    shifted_windows : bool
        Reject matches next to a disparity jump that a neighbouring disparity beats on the best
        of the windows containing the pixel (:mod:`stereo_obstacles.shifted_windows`; not part
        of the published method): fewer foreground-fattening errors, slightly lower density.
        On by default since, with ``tau = 0.55``, it lowers bad-1 on all four Middlebury pairs
        (docs/matching.md, "Defaults"); ``shifted_windows=False, tau=0.6, mu=0.1, max_candidates=10,
        speckle_size=0, bands=1`` is the published method.
    speckle_size : int
        Regions of at most this many matched pixels whose disparities agree within
        ``speckle_range`` but not with their surroundings are removed
        (:mod:`stereo_obstacles.speckles`; not part of the published method); 0 keeps them.
    speckle_range : float
        Largest disparity step between 4-neighbours of one region, pixels.

    Returns
    -------
    MatchResult

    Raises
    ------
    ImageMismatchError
        The images differ in shape.
    InvalidInputError
        An image is too small, too large for the memory (:mod:`stereo_obstacles.match_memory`)
        or not an image, or an option is out of range.

    Notes
    -----
    An empty result (density 0), a density below :data:`LOW_DENSITY` or matches nearly all at
    disparity 0 (identical images) log a warning instead of raising: the result is honest.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(1)
    >>> right = rng.uniform(0, 255, (40, 60)).astype(np.float32)
    >>> left = np.roll(right, 4, axis=1)          # every left pixel is 4 px right of its match
    >>> result = match(left, right, max_disparity=10)
    >>> round(float(np.nanmedian(result.disparity)), 3)
    4.0
    """
    t0 = time.perf_counter()
    _check_options(tau, mu, max_candidates, final_margin, similarity, variant, min_disparity, max_disparity,
                   margin_reference, seeds, seed_points, seed_spacing, rng_seed, bands, speckle_size, speckle_range)
    left_grey, right_grey = grey_pair(left, right)
    check_same_size(left_grey, right_grey)
    h, w = left_grey.shape
    if h < MIN_SIZE or w < MIN_SIZE:
        raise InvalidInputError(f"left, right: images must be at least {MIN_SIZE}x{MIN_SIZE} pixels, got {w}x{h}")
    check_matching_size(w, h)
    d_min, d_max = disparity_range(w, min_disparity, max_disparity)
    inputs = prepare_similarity(left_grey, right_grey, kind=similarity, min_std=min_std, n_threads=int(bands))
    t1 = time.perf_counter()

    if seed_points is not None:
        found = user_seeds(inputs, seed_points, d_min=d_min, d_max=d_max)
    else:
        found = find_seeds(inputs, left_grey, seeds, d_min=d_min, d_max=d_max, tau=tau, margin=seed_margin,
                           rng_seed=rng_seed, spacing=seed_spacing, n_threads=int(bands))
    t2 = time.perf_counter()

    scanned_hi = found.scanned_hi if found.scanned_hi is not None else np.full((h, w), NOT_SCANNED, np.int32)
    banded = match_bands(inputs, found, scanned_hi=scanned_hi, n_bands=int(bands), d_min=d_min, d_max=d_max, tau=tau,
                         mu=mu, max_candidates=int(max_candidates), margin_reference=margin_reference,
                         greedy=variant == "greedy", final_margin=final_margin, shifted_windows=shifted_windows)

    # flat indices: NumPy scatters and gathers them ~2x faster than (row, column) pairs
    flat = banded.y.astype(np.int64) * w + banded.x
    md = banded.x - banded.x_right
    disparity = np.full((h, w), np.nan, np.float32)
    sim = np.full((h, w), np.nan, np.float32)
    disparity.ravel()[flat] = md + banded.offset
    sim.ravel()[flat] = banded.similarity
    t_filled = time.perf_counter()
    speckles = speckle_mask(disparity, max_size_px=int(speckle_size), max_difference_px=float(speckle_range))
    n_speckle = int(np.count_nonzero(speckles))
    if n_speckle:
        disparity[speckles] = np.nan
        sim[speckles] = np.nan
    # matches left, and those at disparity 0 (for the warning), without filtering every match
    at_zero = flat[md == 0]
    n_matched = md.size - n_speckle
    n_zero = at_zero.size - (int(np.count_nonzero(speckles.ravel()[at_zero])) if n_speckle else 0)
    t5 = time.perf_counter()

    n_visited = found.n_evaluated + banded.n_computed - banded.n_rescanned
    n_range = d_max - d_min + 1
    stats = MatchStats(
        n_seeds=int(np.count_nonzero(found.similarity >= tau)), n_seed_pixels=found.n_candidates,
        n_candidates=banded.n_candidates, n_visited=int(n_visited), n_memo_overflow=banded.n_overflow,
        visited_fraction_full=n_visited / (w * w * h), visited_fraction_range=n_visited / (w * h * n_range),
        density=n_matched / (w * h), d_min=d_min, d_max=d_max,
        prepare_seconds=t1 - t0, seeds_seconds=t2 - t1, growth_seconds=banded.growth_seconds,
        final_seconds=banded.matched_seconds - banded.growth_seconds,
        subpixel_seconds=t_filled - t2 - banded.checked_seconds,
        match_seconds=t2 - t1 + banded.checked_seconds + t5 - t_filled, total_seconds=t5 - t0,
        n_edge_checked=banded.n_edge_checked, n_edge_rejected=banded.n_edge_rejected,
        edge_check_seconds=banded.checked_seconds - banded.matched_seconds,
        n_speckle_removed=n_speckle, speckle_seconds=t5 - t_filled)
    _warn_if_doubtful(stats.density, stats.n_seed_pixels, stats.n_seeds,
                      n_zero / n_matched if n_matched else 0.0, d_min, tau, seed_points is not None)
    logger.info("GCS: %d seeds, %d candidates, density %.1f %%, match %.1f ms", stats.n_seeds,
                stats.n_candidates, 100 * stats.density, 1e3 * stats.match_seconds)
    return MatchResult(disparity, sim, stats)


def warm_up() -> float:
    """Compile (or load from the cache) every matching kernel; returns the seconds it took."""
    t0 = time.perf_counter()
    rng = np.random.default_rng(0)
    right = rng.uniform(0, 255, (24, 32)).astype(np.float32)
    left = np.roll(right, 3, axis=1)
    for kind in KINDS:
        for variant in VARIANTS:
            match(left, right, max_disparity=6, similarity=kind, variant=variant)
    return time.perf_counter() - t0
