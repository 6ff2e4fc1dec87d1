"""How well detected obstacles agree with the synthetic world's ground truth.

A true obstacle is *found* when a detected obstacle covers at least ``min_overlap`` of the
true obstacle's pixels that the detection could see, or most of the detection lies on it.
The reported distance is compared with the true ``nearest_depth_m`` (the smallest camera
depth among the obstacle's visible pixels), because that is what the detector measures: the
depth of the near face, not the walking distance along the ground. A detection lying mostly
on pixels that are truly ground, shadow or a marking is a false alarm, reported with the
ground-truth class it lies on.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from stereo_obstacles.labels import Label
from stereo_obstacles.obstacles import ObstacleList


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
                       truths, *, min_overlap: float = 0.2) -> tuple[list[TruthComparison], list[FalseAlarm]]:
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
        the detection that must lie on the true obstacle, for the obstacle to count as found.
    """
    id_map = obstacle_list.id_map
    detected = {o.id: o for o in obstacle_list.obstacles}
    n_ids = max(detected, default=0) + 1
    n_truths = int(instances.max(initial=0)) + 1
    overlap = np.zeros((n_truths, n_ids), dtype=np.int64)
    np.add.at(overlap, (instances.ravel().astype(np.int64), id_map.ravel().astype(np.int64)), 1)
    detection_sizes = overlap.sum(axis=0)
    comparisons = []
    for truth in sorted(truths, key=lambda t: t.nearest_depth_m or math.inf):
        if truth.visible_pixels == 0:
            continue
        row = overlap[truth.obstacle_id, 1:] if truth.obstacle_id < n_truths else np.zeros(n_ids - 1, np.int64)
        best = int(np.argmax(row)) + 1 if row.size and row.max() > 0 else None
        found = best is not None and (row[best - 1] >= min_overlap * truth.visible_pixels
                                      or row[best - 1] >= min_overlap * detection_sizes[best])
        comparisons.append(TruthComparison(
            truth_id=truth.obstacle_id, kind=truth.kind, height_m=float(truth.size_m[2]),
            true_distance_m=truth.nearest_depth_m, visible_pixels=truth.visible_pixels,
            detected_id=best if found else None,
            detected_distance_m=detected[best].distance_m if found else None))
    alarms = []
    for o in obstacle_list.obstacles:
        pixels = id_map == o.id
        on_obstacle = np.count_nonzero(pixels & (true_labels == Label.OBSTACLE))
        if on_obstacle < 0.5 * np.count_nonzero(pixels):
            classes, counts = np.unique(true_labels[pixels & (true_labels != Label.OBSTACLE)], return_counts=True)
            alarms.append(FalseAlarm(o.id, o.distance_m, Label(int(classes[np.argmax(counts)])).name.lower()))
    return comparisons, alarms
