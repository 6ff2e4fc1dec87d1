"""How well phase 1 tells obstacles from ground, measured against label ground truth.

Scores (obstacle = positive, ground = negative):

* ``BER = 100 * (1 - (TP / Npos + TN / Nneg) / 2)``, the balanced error rate;
* obstacle recall ``TP / Npos``;
* the fraction of true shadow pixels called obstacle;
* the fraction of true ground (lit or shadow) pixels called obstacle.

Ground truth classes: GROUND and SHADOW are negatives (a shadow is ground), OBSTACLE is
positive. SKY is ignored (not in front of the walker). MARKING (paint on the ground) is
ignored in the BER: colour alone cannot tell paint from an object, and phase 3 rejects flat
markings with the ground plane; the fraction of marking pixels called obstacle is reported
separately. A predicted UNKNOWN is counted as wrong for both classes (neither a detected
obstacle nor confirmed ground), so abstaining never improves a score.

Real images have no label ground truth; :func:`kitti_truth` derives it from the KITTI
ground-truth disparity: the road plane is fitted robustly in ``(x, y, d)`` to the lower half
of the image; pixels within ``ground_tolerance`` of it are ground, pixels clearly in front
of it (larger disparity) are obstacles, the rest (no LiDAR point, or ambiguous) unknown.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import asdict, dataclass, replace

import numpy as np

from stereo_obstacles.errors import ImageMismatchError, InvalidInputError
from stereo_obstacles.field_checks import check_numbers
from stereo_obstacles.ground_plane import GroundPlane, PlaneFitParameters, fit_ground_plane
from stereo_obstacles.labels import Label
from stereo_obstacles.segmentation import SegmentationParameters, segment


@dataclass(frozen=True)
class SegmentationCounts:
    """Pixel counts of one or more images (counts add up over images).

    Attributes
    ----------
    n_obstacle, n_ground, n_shadow, n_marking
        True obstacle, ground (lit, excluding shadow), shadow and marking pixels.
    obstacle_hit
        True obstacle pixels predicted OBSTACLE.
    ground_kept, shadow_kept
        True ground / shadow pixels predicted GROUND or SHADOW.
    ground_to_obstacle, shadow_to_obstacle, marking_to_obstacle
        True ground / shadow / marking pixels predicted OBSTACLE.
    n_unknown
        Scored (non-SKY, non-MARKING) pixels predicted UNKNOWN.
    """

    n_obstacle: int = 0
    n_ground: int = 0
    n_shadow: int = 0
    n_marking: int = 0
    obstacle_hit: int = 0
    ground_kept: int = 0
    shadow_kept: int = 0
    ground_to_obstacle: int = 0
    shadow_to_obstacle: int = 0
    marking_to_obstacle: int = 0
    n_unknown: int = 0

    def __post_init__(self) -> None:
        for name, value in asdict(self).items():
            if value < 0:
                raise InvalidInputError(f"{name} must be >= 0, got {value}")

    def __add__(self, other: SegmentationCounts) -> SegmentationCounts:
        return SegmentationCounts(**{k: v + getattr(other, k) for k, v in asdict(self).items()})

    @property
    def recall(self) -> float:
        """Obstacle recall ``TP / Npos`` in [0, 1] (NaN without obstacles)."""
        return _ratio(self.obstacle_hit, self.n_obstacle)

    @property
    def ground_specificity(self) -> float:
        """``TN / Nneg``: ground and shadow pixels kept as ground (NaN without ground)."""
        return _ratio(self.ground_kept + self.shadow_kept, self.n_ground + self.n_shadow)

    @property
    def ber_percent(self) -> float:
        """Balanced error rate, percent."""
        return 100.0 * (1.0 - 0.5 * (self.recall + self.ground_specificity))

    @property
    def shadow_to_obstacle_rate(self) -> float:
        """Fraction of true shadow pixels called obstacle (NaN without shadow)."""
        return _ratio(self.shadow_to_obstacle, self.n_shadow)

    @property
    def ground_to_obstacle_rate(self) -> float:
        """Fraction of true ground and shadow pixels called obstacle."""
        return _ratio(self.ground_to_obstacle + self.shadow_to_obstacle, self.n_ground + self.n_shadow)

    @property
    def marking_to_obstacle_rate(self) -> float:
        """Fraction of marking pixels called obstacle (not part of the BER)."""
        return _ratio(self.marking_to_obstacle, self.n_marking)

    def summary(self) -> dict:
        """JSON-ready scores and counts."""
        return {"ber_percent": self.ber_percent, "obstacle_recall": self.recall,
                "shadow_to_obstacle": self.shadow_to_obstacle_rate,
                "ground_to_obstacle": self.ground_to_obstacle_rate,
                "marking_to_obstacle": self.marking_to_obstacle_rate, "counts": asdict(self)}


def _ratio(numerator: int, denominator: int) -> float:
    return numerator / denominator if denominator else math.nan


def count_segmentation(predicted: np.ndarray, truth: np.ndarray) -> SegmentationCounts:
    """Compare predicted labels with ground-truth labels.

    Parameters
    ----------
    predicted
        ``uint8 (H, W)`` from :func:`~stereo_obstacles.segmentation.segment`.
    truth
        ``uint8 (H, W)`` :class:`~stereo_obstacles.labels.Label` ground truth (GROUND, SHADOW,
        OBSTACLE, MARKING, SKY; UNKNOWN pixels are ignored).

    Returns
    -------
    SegmentationCounts

    Examples
    --------
    >>> import numpy as np
    >>> truth = np.array([[1, 2, 3, 3]], dtype=np.uint8)
    >>> predicted = np.array([[1, 3, 3, 1]], dtype=np.uint8)
    >>> c = count_segmentation(predicted, truth)
    >>> c.recall, c.shadow_to_obstacle_rate, c.ber_percent
    (0.5, 1.0, 50.0)
    """
    p = np.asarray(predicted)
    t = np.asarray(truth)
    if p.dtype != np.uint8 or t.dtype != np.uint8 or p.ndim != 2:
        raise InvalidInputError(f"labels must be uint8 (H, W), got {p.dtype} {p.shape} and {t.dtype} {t.shape}")
    if p.shape != t.shape:
        raise ImageMismatchError(f"predicted labels {p.shape} and truth {t.shape} differ in shape")
    said_obstacle = p == Label.OBSTACLE.value
    said_ground = (p == Label.GROUND.value) | (p == Label.SHADOW.value)
    obstacle, ground, shadow, marking = (t == v.value for v in (Label.OBSTACLE, Label.GROUND, Label.SHADOW,
                                                                Label.MARKING))
    scored = obstacle | ground | shadow

    def n(mask: np.ndarray) -> int:
        return int(np.count_nonzero(mask))

    return SegmentationCounts(
        n_obstacle=n(obstacle), n_ground=n(ground), n_shadow=n(shadow), n_marking=n(marking),
        obstacle_hit=n(obstacle & said_obstacle), ground_kept=n(ground & said_ground),
        shadow_kept=n(shadow & said_ground), ground_to_obstacle=n(ground & said_obstacle),
        shadow_to_obstacle=n(shadow & said_obstacle), marking_to_obstacle=n(marking & said_obstacle),
        n_unknown=n(scored & (p == Label.UNKNOWN.value)))


@dataclass(frozen=True)
class KittiTruthParameters:
    """How ground truth labels are derived from a ground-truth disparity map.

    Attributes
    ----------
    ground_tolerance_px, ground_tolerance_fraction
        A pixel is ground when ``|d - plane| <= max(px, fraction * plane)``.
    obstacle_margin_px, obstacle_margin_fraction
        A pixel is an obstacle when ``d - plane > max(px, fraction * plane)`` (clearly in
        front of the road), or when it has a disparity and the plane is at or beyond the
        horizon there.
    fit_rows_from
        The plane is fitted to rows from this fraction of the height downwards.
    plane
        RANSAC settings; ``min_slope_y`` excludes walls and car backs (KITTI's road has
        ``b = B / h = 0.54 / 1.65 = 0.33``).
    """

    ground_tolerance_px: float = 1.0
    ground_tolerance_fraction: float = 0.05
    obstacle_margin_px: float = 3.0
    obstacle_margin_fraction: float = 0.15
    fit_rows_from: float = 0.5
    plane: PlaneFitParameters = PlaneFitParameters(inlier_threshold_px=1.0, min_slope_y=0.1)

    def __post_init__(self) -> None:
        check_numbers(self, tuple((name, 0.0, math.inf) for name in (
            "ground_tolerance_px", "ground_tolerance_fraction", "obstacle_margin_px", "obstacle_margin_fraction")))
        check_numbers(self, (("fit_rows_from", 0.0, 1.0),))
        if self.fit_rows_from == 1.0:
            raise InvalidInputError("fit_rows_from must be below 1 (no row would be fitted), got 1.0")


def kitti_truth(disparity: np.ndarray, *, params: KittiTruthParameters = KittiTruthParameters()
                ) -> tuple[np.ndarray, GroundPlane]:
    """Ground/obstacle labels from a ground-truth disparity map and the fitted road plane.

    Parameters
    ----------
    disparity
        ``float (H, W)`` ground-truth disparity, pixels, NaN where unknown.
    params
        Tolerances and the plane fit.

    Returns
    -------
    labels : numpy.ndarray
        ``uint8 (H, W)``: GROUND, OBSTACLE, or UNKNOWN (no ground truth or ambiguous).
    plane : GroundPlane
    """
    d = np.asarray(disparity)
    if d.ndim != 2 or not np.issubdtype(d.dtype, np.floating):
        raise InvalidInputError(f"disparity must be float (H, W), got {d.dtype} {d.shape}")
    height, width = d.shape
    rows = np.zeros(d.shape, dtype=bool)
    rows[int(params.fit_rows_from * height):] = True
    plane = fit_ground_plane(d, mask=rows, params=params.plane)
    expected = plane.disparity_map(height, width)
    residual = d - expected
    known = np.isfinite(d)
    with np.errstate(invalid="ignore"):
        ground = known & (expected > 0) & (np.abs(residual) <= np.maximum(
            params.ground_tolerance_px, params.ground_tolerance_fraction * expected))
        obstacle = known & ((expected <= 0) | (residual > np.maximum(
            params.obstacle_margin_px, params.obstacle_margin_fraction * expected)))
    labels = np.full(d.shape, Label.UNKNOWN, dtype=np.uint8)
    labels[ground] = Label.GROUND
    labels[obstacle] = Label.OBSTACLE
    return labels, plane




@dataclass(frozen=True)
class SceneScore:
    """Counts for one image, with the shadow rule on and off.

    Attributes
    ----------
    name
        ``"synthetic-<seed>"`` or the KITTI frame name.
    ground
        Ground material (synthetic) or ``"road"`` (KITTI).
    sun_azimuth_deg, sun_elevation_deg
        Sun direction of a synthetic scene, degrees; None for photographs.
    with_rule, without_rule
        Counts with ``shadow_rule`` on (the method) and off (the ablation).
    """

    name: str
    ground: str
    sun_azimuth_deg: float | None
    sun_elevation_deg: float | None
    with_rule: SegmentationCounts
    without_rule: SegmentationCounts

    def summary(self) -> dict:
        """JSON-ready record."""
        return {"name": self.name, "ground": self.ground, "sun_azimuth_deg": self.sun_azimuth_deg,
                "sun_elevation_deg": self.sun_elevation_deg, "shadow_rule_on": self.with_rule.summary(),
                "shadow_rule_off": self.without_rule.summary()}


def score_image(rgb: np.ndarray, truth: np.ndarray, *, name: str, ground: str,
                params: SegmentationParameters = SegmentationParameters(),
                sun: tuple[float, float] | None = None, right: np.ndarray | None = None) -> SceneScore:
    """Segment one image with the shadow rule on and off and count against ``truth``.

    With ``right`` (the right image of the rectified pair) the stereo ground check is used too.
    """
    counts = []
    for rule in (True, False):
        result = segment(rgb, right=right, params=replace(params, shadow_rule=rule))
        counts.append(count_segmentation(result.labels, truth))
    return SceneScore(name=name, ground=ground, sun_azimuth_deg=None if sun is None else sun[0],
                      sun_elevation_deg=None if sun is None else sun[1], with_rule=counts[0],
                      without_rule=counts[1])


def evaluate_synthetic(seeds: Iterable[int], *, params: SegmentationParameters = SegmentationParameters(),
                       width_px: int = 640, height_px: int = 480, noise_sigma: float = 2.0,
                       stereo: bool = True,
                       progress: Callable[[SceneScore], None] | None = None) -> list[SceneScore]:
    """Score phase 1 on random synthetic scenes (one per seed) against their label truth.

    Each seed draws its ground material, sun direction, obstacles (the first a dark box of
    the ground's hue), markings and an off-screen tree whose shadow usually covers the
    reference area (:func:`stereo_obstacles.synthetic.random_scene`). The pair is rendered
    with sensor noise ``noise_sigma`` grey levels; the left image is segmented, with the
    stereo ground check on the right image when ``stereo`` (False: colour alone).
    """
    from stereo_obstacles.synthetic import RenderOptions, random_scene, render_pair

    scores = []
    for seed in seeds:
        scene = random_scene(int(seed), width_px=width_px, height_px=height_px)
        pair = render_pair(scene, RenderOptions(noise_sigma=noise_sigma))
        info = scene.description
        score = score_image(pair.left, pair.labels, name=f"synthetic-{seed}", ground=str(info["ground"]),
                            params=params, sun=(float(info["sun_azimuth_deg"]),
                                                float(info["sun_elevation_deg"])),
                            right=pair.right if stereo else None)
        scores.append(score)
        if progress is not None:
            progress(score)
    return scores


def total(scores: Iterable[SceneScore], *, rule: bool = True) -> SegmentationCounts:
    """Pixel counts pooled over scenes (the shadow rule on or off)."""
    pooled = SegmentationCounts()
    for score in scores:
        pooled = pooled + (score.with_rule if rule else score.without_rule)
    return pooled


__all__ = ["SegmentationCounts", "count_segmentation", "KittiTruthParameters", "kitti_truth",
           "SceneScore", "score_image", "evaluate_synthetic", "total"]
