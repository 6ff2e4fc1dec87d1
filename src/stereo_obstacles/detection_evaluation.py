"""How well detected obstacles agree with the synthetic world's ground truth.

A true obstacle is *found* when a detected obstacle covers at least ``min_overlap`` of the
true obstacle's pixels, or at least ``min_overlap`` of the detection lies on it; any detection
that passes counts (the one overlapping the obstacle most among them gives the distance), not
only the detection overlapping it most: a small far object may be found by its own detection
while a larger neighbour's fringe covers more of its pixels.
The reported distance is compared with the true ``nearest_depth_m`` (the smallest camera
depth among the obstacle's visible pixels), because that is what the detector measures: the
depth of the near face, not the walking distance along the ground. A detection with fewer
than ``FALSE_ALARM_MAX_ON_OBSTACLE`` of its pixels on true obstacles is a false alarm, reported
with the ground-truth class most of it lies on (a thin pole fattened by the matching into the
sky around it is still the pole, not a false alarm).

An obstacle counts in :func:`summarise` by its *stereo-visible* pixels, those the right camera
sees as well (the renderer's ``nonocc`` mask): a part seen by the left camera alone cannot be
ranged by any stereo method (a cylinder 8.3 m away showing 416 pixels beside a pole 2.7 m
away, only 110 of them to both cameras).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.labels import Label
from stereo_obstacles.obstacles import ObstacleList
from stereo_obstacles.scan_evaluation import ScanComparison, ScanSummary, compare_scan_with_truth, summarise_scans


FALSE_ALARM_MAX_ON_OBSTACLE = 0.2
"""A detection with less than this fraction of its pixels on true obstacles is a false alarm."""

MIN_HEIGHT_M = 0.3
"""Default least height (metres) of the true obstacles the figures count (issue 5's "taller than
a set height")."""

MAX_DISTANCE_M = 10.0
"""Default greatest true distance (metres, nearest visible depth) of the true obstacles counted."""

MIN_STEREO_VISIBLE_PX = 200
"""Default least number of a true obstacle's pixels that both cameras see for it to count: no
stereo method can range a part only one camera sees."""


@dataclass(frozen=True)
class TruthComparison:
    """One true obstacle and the detection that found it (if any). Distances in metres."""

    truth_id: int
    kind: str
    height_m: float
    true_distance_m: float | None
    visible_pixels: int
    detected_id: int | None
    detected_distance_m: float | None
    stereo_visible_pixels: int | None = None
    """Visible pixels the right camera sees too (``None``: not known, taken as ``visible_pixels``)."""

    @property
    def relative_error(self) -> float | None:
        """``(detected - true) / true`` distance, or ``None`` when not found."""
        if self.detected_distance_m is None or self.true_distance_m is None:
            return None
        return (self.detected_distance_m - self.true_distance_m) / self.true_distance_m

    def to_dict(self) -> dict:
        """JSON-ready mapping including the relative error."""
        return {**asdict(self), "relative_error": self.relative_error}


@dataclass(frozen=True)
class FalseAlarm:
    """A detection that lies mostly on what is truly not an obstacle."""

    detected_id: int
    distance_m: float | None
    lies_on: str


def compare_with_truth(obstacle_list: ObstacleList, instances: np.ndarray, true_labels: np.ndarray,
                       truths, *, min_overlap: float = 0.2,
                       seen_by_both: np.ndarray | None = None) -> tuple[list[TruthComparison], list[FalseAlarm]]:
    """Pair detections with true obstacles through their pixels.

    Parameters
    ----------
    obstacle_list
        Detections, whose ``id_map`` says which pixels each one covers.
    instances
        ``uint8 (H, W)`` true obstacle id per pixel, 0 for none.
    true_labels
        ``uint8 (H, W)`` true :class:`~stereo_obstacles.labels.Label` per pixel.
    truths
        The true obstacles (``stereo_obstacles.synthetic.ObstacleTruth``); off-screen ones
        (``visible_pixels == 0``) are left out.
    min_overlap
        Fraction of a true obstacle's visible pixels a detection must cover, or fraction of
        the detection that must lie on the true obstacle, for the obstacle to count as found
        (by any detection that passes; the one overlapping it most gives the distance).
    seen_by_both
        ``(H, W)``, non-zero where the right camera sees the left pixel too (the renderer's
        ``nonocc``); gives each comparison's ``stereo_visible_pixels``. The true distance stays
        the nearest depth over all visible pixels (a wall's nearest point may lie in the strip
        only the left camera sees: :mod:`stereo_obstacles.blind_strip`).

    Raises
    ------
    InvalidInputError
        ``seen_by_both`` of another shape than ``instances``.
    """
    id_map = obstacle_list.id_map
    detected = {o.id: o for o in obstacle_list.obstacles}
    n_ids = max(detected, default=0) + 1
    n_truths = int(instances.max(initial=0)) + 1
    overlap = np.zeros((n_truths, n_ids), dtype=np.int64)
    stereo_visible = None
    if seen_by_both is not None:
        seen_by_both = np.asarray(seen_by_both).astype(bool)
        if seen_by_both.shape != instances.shape:
            raise InvalidInputError(f"seen_by_both {seen_by_both.shape} must have the shape of instances "
                                    f"{instances.shape}")
        stereo_visible = np.bincount(instances[seen_by_both].astype(np.int64), minlength=n_truths)
    np.add.at(overlap, (instances.ravel().astype(np.int64), id_map.ravel().astype(np.int64)), 1)
    detection_sizes = overlap.sum(axis=0)
    comparisons = []
    for truth in sorted(truths, key=lambda t: t.nearest_depth_m or math.inf):
        if truth.visible_pixels == 0:
            continue
        row = overlap[truth.obstacle_id, 1:] if truth.obstacle_id < n_truths else np.zeros(n_ids - 1, np.int64)
        qualifies = (row > 0) & ((row >= min_overlap * truth.visible_pixels)
                                 | (row >= min_overlap * detection_sizes[1:]))
        found = bool(qualifies.any())
        best = int(np.argmax(np.where(qualifies, row, -1))) + 1 if found else None
        comparisons.append(TruthComparison(
            truth_id=truth.obstacle_id, kind=truth.kind, height_m=float(truth.size_m[2]),
            true_distance_m=truth.nearest_depth_m, visible_pixels=truth.visible_pixels,
            detected_id=best if found else None,
            detected_distance_m=detected[best].distance_m if found else None,
            stereo_visible_pixels=None if stereo_visible is None or truth.obstacle_id >= n_truths
            else int(stereo_visible[truth.obstacle_id])))
    alarms = []
    for o in obstacle_list.obstacles:
        pixels = id_map == o.id
        on_obstacle = np.count_nonzero(pixels & (true_labels == Label.OBSTACLE.value))
        if on_obstacle < FALSE_ALARM_MAX_ON_OBSTACLE * np.count_nonzero(pixels):
            classes, counts = np.unique(true_labels[pixels & (true_labels != Label.OBSTACLE.value)], return_counts=True)
            alarms.append(FalseAlarm(o.id, o.distance_m, Label(int(classes[np.argmax(counts)])).name.lower()))
    return comparisons, alarms


def repeated_detections(obstacle_list: ObstacleList, instances: np.ndarray) -> tuple[int, ...]:
    """Ids of the detections that repeat an obstacle: more than half of their pixels lie on one
    true obstacle that a larger detection (of equal size: a lower id) also lies mostly on (one wall
    listed twice).
    ``obstacle_list`` and ``instances`` as for :func:`compare_with_truth`."""
    majority = {}
    for o in sorted(obstacle_list.obstacles, key=lambda o: (-o.pixel_count, o.id)):
        counts = np.bincount(instances[obstacle_list.id_map == o.id].astype(np.int64))
        if counts.size > 1 and 2 * counts[1:].max() > counts.sum():
            majority.setdefault(int(np.argmax(counts[1:])) + 1, []).append(o.id)
    return tuple(sorted(i for ids in majority.values() for i in ids[1:]))


@dataclass(frozen=True)
class SceneEvaluation:
    """The comparison of one rendered scene's detections with its truth."""

    seed: int
    ground: str
    comparisons: tuple[TruthComparison, ...]
    false_alarms: tuple[FalseAlarm, ...]
    seconds: float
    n_detections: int = 0
    n_repeated: int = 0
    """Detections that repeat an obstacle a larger one covers (:func:`repeated_detections`)."""
    scan: ScanComparison | None = None
    """The free range per direction beside its truth (:mod:`stereo_obstacles.scan_evaluation`)."""


@dataclass(frozen=True)
class DetectionSummary:
    """Figures over many scenes for true obstacles at least ``min_height_m`` high and nearer
    than ``max_distance_m`` (nearest visible depth), with at least ``min_visible_px`` pixels seen
    by both cameras."""

    n_scenes: int
    n_obstacles: int
    n_found: int
    median_abs_error_pct: float | None
    p95_abs_error_pct: float | None
    max_abs_error_pct: float | None
    false_alarms_on_shadow: int
    false_alarms_on_marking: int
    false_alarms_other: int
    median_seconds: float
    min_height_m: float
    max_distance_m: float
    min_visible_px: int
    missed: tuple[str, ...]
    large_errors: tuple[str, ...] = ()
    """The found obstacles whose distance error exceeds ``LARGE_ERROR_PCT`` (the issue's worst-error
    target), worst first, e.g. ``"seed 14: #5 wall at 2.65 m, reported 2.98 m (+12.3 %)"``."""
    n_detections: int = 0
    n_repeated: int = 0
    """Detections, of all scenes, that repeat an obstacle a larger one covers."""
    scan: ScanSummary | None = None
    """The free range per direction over the scenes' sectors (those evaluated with a scan)."""

    def to_dict(self) -> dict:
        """JSON-ready mapping."""
        return asdict(self)


EVALUATION_SUPERSAMPLE = 3
"""Rays per pixel along each axis when a scene is rendered for the evaluation.

A camera pixel integrates the light falling on its area. Rendered with one ray through its
centre, each outline of a thin object lands on whole pixels, in each image independently (up
to 0.5 px off), so the pair shows a disparity up to 1 px away from the true one: scene 11's
pole at 9.96 m (true 6.60 px) has its edges 7 px apart in the pair, and its pixels read
+0.30 px (median) with one ray against -0.04 px with 3 x 3 rays (``docs/pipeline.md``). 3 x 3
rays bound the error at 1/6 px per outline, 1/3 px in disparity."""


def evaluate_synthetic_scene(seed: int, *, width_px: int = 640, height_px: int = 480, config=None,
                             render_options=None, min_height_m: float = MIN_HEIGHT_M) -> SceneEvaluation:
    """Render scene ``seed`` (0 = the built-in one) with ``render_options``
    (:class:`~stereo_obstacles.synthetic.RenderOptions`; default: ``EVALUATION_SUPERSAMPLE`` rays
    per pixel along each axis, no noise, uncompressed), detect, compare with the truth (the
    scan's with the true obstacles at least ``min_height_m`` high)."""
    from stereo_obstacles.synthetic import RenderOptions, default_scene, random_scene, render_pair

    scene = default_scene(width_px, height_px) if seed == 0 else random_scene(seed, width_px=width_px,
                                                                              height_px=height_px)
    pair = render_pair(scene, render_options or RenderOptions(supersample=EVALUATION_SUPERSAMPLE))
    return evaluate_rendered_pair(seed, scene.ground.name, pair, config=config, min_height_m=min_height_m)


def evaluate_rendered_pair(seed: int, ground: str, pair, *, config=None,
                           min_height_m: float = MIN_HEIGHT_M) -> SceneEvaluation:
    """:func:`evaluate_synthetic_scene` of a pair already rendered
    (:class:`~stereo_obstacles.synthetic.SyntheticPair` of scene ``seed``, whose ground material is
    named ``ground``): detect with ``config`` (default :class:`~stereo_obstacles.pipeline.DetectionConfig`),
    timed, and compare with the truth."""
    import time

    from stereo_obstacles.pipeline import DetectionConfig, detect

    started = time.perf_counter()
    result = detect(pair.left, pair.right, pair.calibration, config=config or DetectionConfig())
    seconds = time.perf_counter() - started
    comparisons, alarms = compare_with_truth(result.obstacles, pair.instances, pair.labels, pair.obstacles,
                                             seen_by_both=pair.nonocc)
    calibration = pair.calibration
    scan = compare_scan_with_truth(result.obstacles.scan, pair.instances,
                                   calibration.focal_baseline_px_m / pair.depth - calibration.doffs_px, pair.nonocc,
                                   pair.obstacles, calibration, min_height_m=min_height_m,
                                   min_pixels=result.config.obstacles.scan_min_pixels)
    return SceneEvaluation(seed=seed, ground=ground, comparisons=tuple(comparisons),
                           false_alarms=tuple(alarms), seconds=seconds, n_detections=len(result.obstacles.obstacles),
                           n_repeated=len(repeated_detections(result.obstacles, pair.instances)), scan=scan)


def _stereo_visible(comparison: TruthComparison) -> int:
    if comparison.stereo_visible_pixels is None:
        return comparison.visible_pixels
    return comparison.stereo_visible_pixels


def is_counted(comparison: TruthComparison, *, min_height_m: float = MIN_HEIGHT_M,
               max_distance_m: float = MAX_DISTANCE_M, min_visible_px: int = MIN_STEREO_VISIBLE_PX) -> bool:
    """Whether :func:`summarise` counts the true obstacle of ``comparison``: at least
    ``min_height_m`` tall, its true distance (nearest visible depth) known and at most
    ``max_distance_m`` (metres), and showing at least ``min_visible_px`` pixels that both cameras
    see (all its visible pixels when that is not known; 0 is known: none)."""
    return (comparison.height_m >= min_height_m and comparison.true_distance_m is not None
            and comparison.true_distance_m <= max_distance_m and _stereo_visible(comparison) >= min_visible_px)


LARGE_ERROR_PCT = 5.0
"""Distance errors above this (per cent) are listed one by one in :class:`DetectionSummary`."""


def summarise(evaluations: list[SceneEvaluation], *, min_height_m: float = MIN_HEIGHT_M,
              max_distance_m: float = MAX_DISTANCE_M, min_visible_px: int = MIN_STEREO_VISIBLE_PX) -> DetectionSummary:
    """Found rate, distance errors and false alarms over many scene evaluations, and the scan's
    figures (:func:`stereo_obstacles.scan_evaluation.summarise_scans` within ``max_distance_m``).
    The scan's truth was set per scene, with the ``min_height_m`` given to
    :func:`evaluate_synthetic_scene`, not this one's.

    Raises
    ------
    InvalidInputError
        ``min_height_m`` not a finite number >= 0 or ``max_distance_m`` not a finite number > 0.
    """
    if not (math.isfinite(min_height_m) and min_height_m >= 0):
        raise InvalidInputError(f"min_height_m: expected a number >= 0 metres, got {min_height_m}")
    if not (math.isfinite(max_distance_m) and max_distance_m > 0):
        raise InvalidInputError(f"max_distance_m: expected a number > 0 metres, got {max_distance_m}")
    relevant = [(e.seed, c) for e in evaluations for c in e.comparisons
                if is_counted(c, min_height_m=min_height_m, max_distance_m=max_distance_m,
                              min_visible_px=min_visible_px)]
    errors = np.array([abs(c.relative_error) * 100 for _, c in relevant if c.relative_error is not None])
    alarms = [a.lies_on for e in evaluations for a in e.false_alarms]
    scans = [e.scan for e in evaluations if e.scan is not None]
    return DetectionSummary(
        n_scenes=len(evaluations), n_obstacles=len(relevant),
        n_found=sum(c.detected_id is not None for _, c in relevant),
        median_abs_error_pct=float(np.median(errors)) if errors.size else None,
        p95_abs_error_pct=float(np.percentile(errors, 95)) if errors.size else None,
        max_abs_error_pct=float(errors.max()) if errors.size else None,
        false_alarms_on_shadow=alarms.count("shadow"), false_alarms_on_marking=alarms.count("marking"),
        false_alarms_other=len(alarms) - alarms.count("shadow") - alarms.count("marking"),
        median_seconds=float(np.median([e.seconds for e in evaluations])) if evaluations else 0.0,
        min_height_m=min_height_m, max_distance_m=max_distance_m, min_visible_px=min_visible_px,
        n_detections=sum(e.n_detections for e in evaluations), n_repeated=sum(e.n_repeated for e in evaluations),
        scan=summarise_scans(scans, max_distance_m=max_distance_m) if scans else None,
        missed=tuple(f"seed {s}: #{c.truth_id} {c.kind} at {c.true_distance_m:.1f} m ({_stereo_visible(c)} px seen by "
                     f"both cameras)"
                     for s, c in relevant if c.detected_id is None),
        large_errors=tuple(f"seed {s}: #{c.truth_id} {c.kind} at {c.true_distance_m:.2f} m, reported "
                           f"{c.detected_distance_m:.2f} m ({100 * c.relative_error:+.1f} %)"
                           for s, c in sorted(((s, c) for s, c in relevant if c.relative_error is not None
                                               and abs(c.relative_error) * 100 > LARGE_ERROR_PCT + 1e-9),
                                              key=lambda sc: -abs(sc[1].relative_error))))
