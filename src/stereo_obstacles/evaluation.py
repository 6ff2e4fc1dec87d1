"""Side-by-side accuracy and speed of stereo matchers on datasets with ground truth.

A small registry names the methods (:data:`METHODS`): our Growing Correspondence Seeds
matcher ``gcs`` and the peers of :mod:`stereo_obstacles.peers` (``sgbm``, ``bm``,
``ncc-wta``). :func:`evaluate_pair` runs each on a :class:`~stereo_obstacles.datasets.StereoPair`
with the same disparity range (the ground truth's largest disparity, rounded up), scores
the result with :func:`~stereo_obstacles.disparity_metrics.evaluate_disparity` over the
non-occluded pixels, and times it:

* ``first_call_seconds``: the first call on the pair; in a fresh process the first pair's
  first call includes numba compilation or cache loading (OpenCV: thread-pool start-up);
* ``median_seconds``: the median of ``repeat`` further calls (steady state).

Times are wall-clock seconds around the whole call, input conversion included, so every
method pays for the same things.
"""

from __future__ import annotations

import importlib.util
import logging
import math
import os
import platform
import statistics
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from stereo_obstacles import __version__
from stereo_obstacles.datasets import StereoPair
from stereo_obstacles.disparity_metrics import DisparityMetrics, evaluate_disparity
from stereo_obstacles.errors import InvalidInputError

logger = logging.getLogger(__name__)

REPORT_FORMAT = "stereo-obstacles/evaluation"
REPORT_VERSION = 1

MethodOutput = tuple[np.ndarray, "dict | None"]
"""What a method returns: the disparity map and optional method statistics (JSON-ready)."""


@dataclass(frozen=True)
class Method:
    """A stereo matcher in the registry.

    Attributes
    ----------
    name : str
        Registry key, used on the command line.
    description : str
        One line for tables and ``--help``.
    run : callable
        ``run(left, right, max_disparity) -> (disparity, stats_or_None)``; images are RGB
        ``uint8 (H, W, 3)``, ``max_disparity`` an int in pixels, the disparity ``float32``
        with NaN where unmatched.
    module : str
        Module the method needs; the method is unavailable when it cannot be found.
    """

    name: str
    description: str
    run: Callable[[np.ndarray, np.ndarray, int], MethodOutput]
    module: str

    @property
    def available(self) -> bool:
        """True when the method's module can be imported."""
        return importlib.util.find_spec(self.module) is not None


def _run_gcs(left: np.ndarray, right: np.ndarray, max_disparity: int) -> MethodOutput:
    from stereo_obstacles.matching import match

    result = match(left, right, max_disparity=max_disparity)
    return result.disparity, result.stats.to_dict()


def _run_sgbm(left: np.ndarray, right: np.ndarray, max_disparity: int) -> MethodOutput:
    from stereo_obstacles.peers import sgbm_disparity

    return sgbm_disparity(left, right, max_disparity=max_disparity), None


def _run_bm(left: np.ndarray, right: np.ndarray, max_disparity: int) -> MethodOutput:
    from stereo_obstacles.peers import bm_disparity

    return bm_disparity(left, right, max_disparity=max_disparity), None


def _run_ncc_wta(left: np.ndarray, right: np.ndarray, max_disparity: int) -> MethodOutput:
    from stereo_obstacles.peers import ncc_wta_disparity

    return ncc_wta_disparity(left, right, max_disparity=max_disparity), None


METHODS: dict[str, Method] = {m.name: m for m in (
    Method("gcs", "Growing Correspondence Seeds, Sobel edge seeds (ours)", _run_gcs,
           "stereo_obstacles.matching"),
    Method("sgbm", "OpenCV StereoSGBM, published settings", _run_sgbm, "stereo_obstacles.peers"),
    Method("bm", "OpenCV StereoBM, published settings", _run_bm, "stereo_obstacles.peers"),
    Method("ncc-wta", "exhaustive NCC 5x5 winner-takes-all", _run_ncc_wta,
           "stereo_obstacles.peers"),
)}
"""The registry of methods, in table order."""


def available_methods() -> tuple[str, ...]:
    """Names of the registered methods whose code is present."""
    return tuple(name for name, method in METHODS.items() if method.available)


def resolve_methods(names: Sequence[str] | None) -> tuple[Method, ...]:
    """The registered methods called ``names`` (default: every available one).

    Raises
    ------
    InvalidInputError
        An unknown or unavailable name, or an empty list.
    """
    if names is None:
        return tuple(METHODS[n] for n in available_methods())
    if isinstance(names, str):
        raise InvalidInputError(f"methods: expected a sequence of method names, got the string {names!r} "
                                f"(write [{names!r}])")
    if not names:
        raise InvalidInputError("methods: give at least one method")
    chosen = []
    for name in names:
        if name not in METHODS:
            raise InvalidInputError(f"methods: unknown method {name!r}; expected some of "
                                    f"{', '.join(METHODS)}")
        if not METHODS[name].available:
            raise InvalidInputError(f"methods: {name!r} is not available in this installation "
                                    f"({METHODS[name].module} is missing)")
        if METHODS[name] not in chosen:
            chosen.append(METHODS[name])
    return tuple(chosen)


@dataclass(frozen=True)
class MethodEvaluation:
    """Accuracy and time of one method on one stereo pair.

    Attributes
    ----------
    pair, layout : str
        Name and dataset layout of the pair.
    method : str
        Registry name of the method.
    width_px, height_px, max_disparity_px : int
        Image size and the disparity range given to the method, pixels.
    metrics : DisparityMetrics
        Accuracy over the pair's non-occluded pixels (every pixel with ground truth when the
        layout has no mask).
    kitti : bool
        True on KITTI layouts, where D1 is the customary figure.
    first_call_seconds : float
        Time of the first call on this pair, seconds.
    median_seconds : float
        Median time of ``runs`` further calls, seconds.
    runs : int
        Number of timed calls after the first (>= 1).
    method_stats : dict or None
        The method's own statistics from the last call (GCS: seeds, visited points, stages).
    """

    pair: str
    layout: str
    method: str
    width_px: int
    height_px: int
    max_disparity_px: int
    metrics: DisparityMetrics
    kitti: bool
    first_call_seconds: float
    median_seconds: float
    runs: int
    method_stats: dict | None = None

    def __post_init__(self) -> None:
        if self.runs < 1:
            raise InvalidInputError(f"runs must be >= 1, got {self.runs}")
        for name in ("first_call_seconds", "median_seconds"):
            value = getattr(self, name)
            if not math.isfinite(value) or value < 0:
                raise InvalidInputError(f"{name} must be >= 0 seconds, got {value}")

    def to_dict(self) -> dict:
        """JSON-ready mapping (metrics nested, NaN as ``None``)."""
        return {
            "pair": self.pair, "layout": self.layout, "method": self.method,
            "width_px": self.width_px, "height_px": self.height_px,
            "max_disparity_px": self.max_disparity_px, "kitti": self.kitti,
            "metrics": self.metrics.to_dict(),
            "first_call_seconds": self.first_call_seconds,
            "median_seconds": self.median_seconds, "runs": self.runs,
            "method_stats": self.method_stats,
        }


def evaluate_pair(pair: StereoPair, methods: Sequence[Method], *,
                  repeat: int = 3) -> list[MethodEvaluation]:
    """Run and score every method on one pair.

    Parameters
    ----------
    pair : StereoPair
        Must have ground truth.
    methods : sequence of Method
        From :func:`resolve_methods`.
    repeat : int
        Timed calls after the first one (>= 1); the median is reported.

    Returns
    -------
    list of MethodEvaluation
        One per method, in the given order.

    Raises
    ------
    InvalidInputError
        The pair has no ground truth, ``repeat < 1``, or a method that is not a :class:`Method`.
    """
    if not isinstance(repeat, int) or isinstance(repeat, bool) or repeat < 1:
        raise InvalidInputError(f"repeat must be an integer >= 1, got {repeat!r}")
    methods = tuple(methods)
    if any(not isinstance(method, Method) for method in methods):
        raise InvalidInputError("methods: expected Method objects (from resolve_methods(names)), got "
                                f"{[type(m).__name__ for m in methods]}")
    max_gt = pair.max_gt_disparity
    if max_gt is None:
        raise InvalidInputError(f"{pair.source}: {pair.name} has no ground-truth disparity to "
                                f"evaluate against")
    max_disparity = max(1, math.ceil(max_gt))
    h, w = pair.left.shape[:2]
    results = []
    for method in methods:
        logger.info("%s: running %s (%d timed runs)", pair.name, method.name, repeat)
        t0 = time.perf_counter()
        method.run(pair.left, pair.right, max_disparity)
        first = time.perf_counter() - t0
        times = []
        for _ in range(repeat):
            t0 = time.perf_counter()
            disparity, stats = method.run(pair.left, pair.right, max_disparity)
            times.append(time.perf_counter() - t0)
        metrics = evaluate_disparity(disparity, pair.gt_disparity, mask=pair.nonocc)
        results.append(MethodEvaluation(
            pair=pair.name, layout=pair.layout, method=method.name, width_px=w, height_px=h,
            max_disparity_px=max_disparity, metrics=metrics, kitti=pair.is_kitti,
            first_call_seconds=first, median_seconds=statistics.median(times), runs=repeat,
            method_stats=stats))
    return results


def machine_info() -> dict:
    """The machine and library versions, for reports next to timings."""
    import cv2
    import numba

    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as handle:
            names = [line.split(":", 1)[1].strip() for line in handle
                     if line.startswith("model name")]
        cpu = names[0] if names else cpu
    except OSError:
        pass
    return {
        "cpu": cpu, "logical_cpus": os.cpu_count(), "system": platform.platform(),
        "python": platform.python_version(), "numpy": np.__version__,
        "opencv": cv2.__version__, "numba": numba.__version__,
        "opencv_threads": cv2.getNumThreads(), "numba_threads": numba.get_num_threads(),
        "stereo_obstacles": __version__,
    }


def report_dict(results: Sequence[MethodEvaluation], *, repeat: int) -> dict:
    """The JSON report: format, version, machine, and every result."""
    return {"format": REPORT_FORMAT, "version": REPORT_VERSION, "repeat": repeat,
            "machine": machine_info(), "results": [r.to_dict() for r in results]}


_COLUMNS = (
    ("pair", 24), ("method", 8), ("dens%", 6), ("bad1%", 6), ("bad2%", 6), ("bad1u%", 6),
    ("bad2u%", 6), ("EPE", 5), ("D1%", 6), ("D1u%", 6), ("first s", 8), ("med s", 8),
)


def format_table(results: Sequence[MethodEvaluation]) -> str:
    """A plain-text table, one row per pair and method.

    ``bad1%``/``bad2%`` are over matched non-occluded pixels, ``bad1u%``/``bad2u%`` count
    unmatched pixels as bad; D1 columns are filled on KITTI pairs only.
    """
    def number(value: float, digits: int) -> str:
        return "-" if value is None or math.isnan(value) else f"{value:.{digits}f}"

    header = " ".join(f"{name:>{width}}" if i > 1 else f"{name:<{width}}"
                      for i, (name, width) in enumerate(_COLUMNS))
    lines = [header, "-" * len(header)]
    for r in results:
        m = r.metrics
        d1 = (m.d1_matched_pct, m.d1_all_pct) if r.kitti else (math.nan, math.nan)
        cells = [r.pair[-24:], r.method, number(m.density_pct, 1), number(m.bad1_matched_pct, 2),
                 number(m.bad2_matched_pct, 2), number(m.bad1_all_pct, 2),
                 number(m.bad2_all_pct, 2), number(m.epe_px, 2), number(d1[0], 2),
                 number(d1[1], 2), number(r.first_call_seconds, 3), number(r.median_seconds, 3)]
        lines.append(" ".join(f"{c:>{w}}" if i > 1 else f"{c:<{w}}"
                              for i, (c, (_, w)) in enumerate(zip(cells, _COLUMNS))))
    return "\n".join(lines)


__all__ = ["METHODS", "Method", "MethodEvaluation", "available_methods", "evaluate_pair",
           "format_table", "machine_info", "report_dict", "resolve_methods"]
