"""The random scenes of ``evaluate-detection``, rendered as it renders them, for end-to-end tests
of one true obstacle: how the pipeline reports it under a configuration."""

from __future__ import annotations

from stereo_obstacles.detection_evaluation import (EVALUATION_SUPERSAMPLE, FalseAlarm, TruthComparison,
                                                   compare_with_truth)
from stereo_obstacles.pipeline import DetectionConfig, detect
from stereo_obstacles.synthetic import ObstacleTruth, RenderOptions, SyntheticPair, random_scene, render_pair


def evaluation_pair(seed: int, noise_sigma: float = 0.0) -> SyntheticPair:
    """``random_scene(seed)`` (640 x 480) rendered with the evaluation's rays per pixel."""
    return render_pair(random_scene(seed), RenderOptions(supersample=EVALUATION_SUPERSAMPLE, noise_sigma=noise_sigma))


def true_obstacle(pair: SyntheticPair, kind: str, nearest_depth_m: float) -> ObstacleTruth:
    """The pair's true obstacle of ``kind`` whose nearest depth is ``nearest_depth_m`` (within 1 cm)."""
    found = [t for t in pair.obstacles if t.kind == kind and t.nearest_depth_m is not None   # off-screen: None
             and abs(t.nearest_depth_m - nearest_depth_m) < 0.01]
    assert found, f"no {kind} at {nearest_depth_m} m in the scene: " \
                  f"{[(t.kind, t.nearest_depth_m) for t in pair.obstacles]}"
    return found[0]


def comparison(pair: SyntheticPair, truth: ObstacleTruth, config: DetectionConfig = DetectionConfig()
               ) -> tuple[TruthComparison, list[FalseAlarm]]:
    """The :class:`~stereo_obstacles.detection_evaluation.TruthComparison` of ``truth`` when the
    pair is detected with ``config``, and the false alarms of that detection."""
    result = detect(pair.left, pair.right, pair.calibration, config=config)
    comparisons, alarms = compare_with_truth(result.obstacles, pair.instances, pair.labels, pair.obstacles,
                                             seen_by_both=pair.nonocc)
    return next(c for c in comparisons if c.truth_id == truth.obstacle_id), alarms   # every visible truth has one
