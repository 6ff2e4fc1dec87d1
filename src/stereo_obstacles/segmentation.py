"""Phase 1: ground, ground in shadow, and obstacles from one colour image (shadow-robust).

Two colour models, chosen by ``SegmentationParameters.colour_model``:

``"log_rgb"`` (default, measured better: docs/segmentation.md) keeps the paper's structure --
reference area, a 7x7 median (majority) filter over per-pixel colour tests, and the rule
ground / shadow (darker within a bounded ratio, same material) / obstacle -- but describes
the ground by the set of its colours and their shadowed and sunlit versions
(:mod:`stereo_obstacles.ground_colour`): a pixel is ground when most measurable pixels of
its window have one kind of match (ground colour, shadow colour or sunlit colour) and its
own colour is near one of them; shadow when the shadow matches dominate; unknown when it is
too dark to measure; obstacle otherwise.

``"hsi"`` is the paper's rule in HSI, corrected:

1. RGB -> HSI with validity thresholds (:mod:`stereo_obstacles.colour`).
2. Reference statistics of the ground from a bottom-centre rectangle, made robust to an
   object or a shadow inside it (:mod:`stereo_obstacles.reference_area`).
3. Colour match to the ground, median-filtered over a 7x7 window counting valid pixels only
   (:mod:`stereo_obstacles.hue_filter`): the circular hue distance to the reference is within
   the hue threshold ``T`` (coloured ground), or the saturation is low (grey ground).
4. Per pixel, with ``I`` its intensity (mean over ``intensity_smoothing_px``) and ``I_ref``
   the reference median:

   * **ground**: the colour matches (median-filtered hue within ``T``, or low saturation on
     grey ground), the pixel's own colour is not far off (``veto_factor``), and ``I`` is
     within the reference intensity range (widened by ``ground_intensity_margin``);
   * **shadow** (when ``shadow_rule``): ``shadow_min_ratio <= I / I_ref <= shadow_max_ratio``
     and the colour is the ground's seen under skylight alone: per-channel ratios to the
     reference colour bluer by at least ``shadow_blue_shift`` and otherwise balanced
     (``shadow_chroma_band``), for the majority of the window. The paper says "above the
     average", a typo: a cast shadow is darker. Its "hue close to the reference" is replaced
     by this ratio test because skylight shifts the hue of a shadow by tens of degrees on
     weakly coloured ground (measured in docs/segmentation.md), and because a dark object
     of exactly the ground's hue is then told from a shadow: it is not bluer;
   * **ground** again when the reference itself lies in shadow: ``1 / shadow_max_ratio <=
     I / I_ref <= 1 / shadow_min_ratio`` and the reverse (yellower) colour shift;
   * **unknown**: too dark to measure colour but bright enough for a shadow;
   * **obstacle**: everything else (including grey objects on coloured ground).
5. Clean-up: obstacle specks smaller than ``min_obstacle_area_px`` become ground (or shadow
   when darker than the ground range). Last (after the stereo cue below, for both colour
   models), holes become obstacle: non-obstacle regions smaller than ``max_hole_area_px``,
   and regions enclosed by obstacle pixels up to ``max_hole_fraction`` of the image. These
   are area tests, so a thin long pole stays.

In both colour models, shadow pixels that have lost the ground's texture (relative to their
brightness) become obstacles: a cast shadow keeps the texture of the ground it falls on, a
smooth dark face does not (:mod:`stereo_obstacles.shadow_texture`, beyond the paper).

Given the right image of a rectified pair as well (``segment(left, right=right)``), a stereo
cue is added to either colour model (:mod:`stereo_obstacles.ground_check`, beyond the paper):
pixels that the right image does not see on the ground plane, estimated from the same
reference area, become obstacles whatever their colour (a box of the ground's own colour, a
dark object read as shadow), and far ground that colour calls obstacle because its colour has
drifted with distance becomes ground again when it has its own row's colour
(:mod:`stereo_obstacles.far_ground`, with the same plane). Nothing above the plane's horizon
is ground: what colour took for ground there (a brick wall over tiles) becomes obstacle. A
cast shadow lies on the ground, so both cameras see it at the plane's disparity and the check has no
reason to flag it (measured in docs/segmentation.md: held-out shadow pixels called obstacle
0.32 % by colour alone, 1.13 % with the check, session 6).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import cv2
import numpy as np

from stereo_obstacles._segmentation_kernel import (classify_kernel, classify_modes_kernel,
                                                   fill_holes_kernel, fill_small_components_kernel,
                                                   match_flags_kernel)
from stereo_obstacles.colour import (DEFAULT_MIN_INTENSITY, DEFAULT_MIN_SATURATION, check_rgb,
                                     check_thresholds, rgb_to_hsi)
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.far_ground import FarGroundParameters, FarGroundRows, far_ground_pixels, far_ground_rows
from stereo_obstacles.field_checks import check_integers, check_numbers, check_types, plain_numbers
from stereo_obstacles.ground_check import (GroundCheck, GroundCheckParameters, check_colour_pair, check_ground,
                                           grey_levels)
from stereo_obstacles.ground_colour import (GroundColourParameters, build_ground_colour_model,
                                            colour_flags)
from stereo_obstacles.hue_filter import DEFAULT_FILTER_SIZE, window_counts
from stereo_obstacles.labels import Label
from stereo_obstacles.reference_area import (DEFAULT_REFERENCE_AREA, ReferenceArea,
                                             ReferenceParameters, ReferenceStatistics,
                                             reference_statistics)
from stereo_obstacles.shadow_texture import ShadowTextureParameters, smooth_pixels, textureless_shadow
from stereo_obstacles.thread_pool import run_each_in_threads

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class SegmentationParameters:
    """Every threshold of phase 1. Defaults chosen by measurement (docs/segmentation.md).

    Attributes
    ----------
    colour_model
        ``"log_rgb"``: ground colours and their relit versions (:mod:`~stereo_obstacles.ground_colour`);
        ``"hsi"``: the paper's hue / intensity rule (the fields from ``shadow_blue_shift`` to
        ``intensity_smoothing_px`` apply to it only).
    ground_colour
        Thresholds of the ``"log_rgb"`` model.
    min_intensity
        Colour is measured only where intensity (fraction of full scale) is at least this.
    min_saturation
        Hue is measured only where saturation is at least this.
    filter_size
        Side of the median window on the colour match, pixels (the paper's 7).
    reference
        Robust reference-area statistics.
    shadow_rule
        Classify darker ground-coloured pixels as shadow (True) or leave them obstacles
        (False, the ablation of the paper's Figs. 13-14).
    shadow_min_ratio, shadow_max_ratio
        Shadow brightness ratio bounds ``alpha <= I / I_ref <= beta``, ``0 < alpha < beta < 1``.
    shadow_blue_shift
        Skylight test: a shadow's blue/red ratio must be at least this times the reference's
        (a cast shadow is lit by the blue sky alone; a dark object of the ground's colour is
        not bluer). When the reference itself lies in shadow, ground brighter by
        ``1 / shadow_max_ratio .. 1 / shadow_min_ratio`` with at most ``1 /`` this times the
        reference's blue/red ratio is sunlit ground. 0 disables the blue test (a dark object
        of the ground's colour then reads as shadow).
    shadow_chroma_band
        The green ratio must be within this factor of the geometric mean of the red and blue
        ratios (``k_G**2 / (k_R k_B)`` in ``[1 / band, band]``): the light changed, not the
        material.
    veto_factor
        A pixel whose own hue is farther than this times the hue threshold from the reference
        (grey ground: whose saturation exceeds this times the ground's saturation limit) is
        not ground, whatever the median says: the median removes noise but would otherwise
        erase obstacles thinner than half the window (poles).
    ground_intensity_margin
        The reference intensity range is widened by this on both sides (fraction of full scale).
    intensity_smoothing_px
        The intensity tests use the mean over a window of this side (1: the pixel itself),
        so that texture and sensor noise do not speckle the ground with obstacles.
    min_obstacle_area_px
        Obstacle regions (8-connected) smaller than this are specks and become ground.
    max_hole_area_px
        Non-obstacle regions (4-connected) smaller than this become obstacle.
    max_hole_fraction
        Non-obstacle regions (4-connected) enclosed by obstacle pixels (not touching the image
        border) of at most this fraction of the image become obstacle: the flat, unmatched
        inside of a car or a box whose outline was found. 0 turns it off.
    shadow_texture
        The shadow texture test (:mod:`~stereo_obstacles.shadow_texture`): shadow pixels much
        smoother than the ground become obstacles (both colour models, when ``shadow_rule``).
    ground_check
        The stereo cue's settings, used when :func:`segment` is given the right image.
    far_ground
        The far rows' own ground colour (:mod:`~stereo_obstacles.far_ground`), with the stereo
        cue's ground plane.
    """

    colour_model: str = "log_rgb"
    ground_colour: GroundColourParameters = field(default_factory=GroundColourParameters)
    min_intensity: float = DEFAULT_MIN_INTENSITY
    min_saturation: float = DEFAULT_MIN_SATURATION
    filter_size: int = DEFAULT_FILTER_SIZE
    reference: ReferenceParameters = field(default_factory=ReferenceParameters)
    shadow_rule: bool = True
    shadow_min_ratio: float = 0.4
    shadow_max_ratio: float = 0.8
    shadow_blue_shift: float = 1.1
    shadow_chroma_band: float = 1.25
    veto_factor: float = 3.0
    ground_intensity_margin: float = 0.02
    intensity_smoothing_px: int = 3
    min_obstacle_area_px: int = 16
    max_hole_area_px: int = 16
    max_hole_fraction: float = 0.02
    shadow_texture: ShadowTextureParameters = field(default_factory=ShadowTextureParameters)
    ground_check: GroundCheckParameters = field(default_factory=GroundCheckParameters)
    far_ground: FarGroundParameters = field(default_factory=FarGroundParameters)

    def __post_init__(self) -> None:
        plain_numbers(self)                      # NumPy scalars as Python numbers (JSON-ready)
        check_thresholds(self.min_intensity, self.min_saturation)
        check_types(self, (("ground_colour", GroundColourParameters), ("reference", ReferenceParameters),
                           ("shadow_texture", ShadowTextureParameters), ("ground_check", GroundCheckParameters),
                           ("far_ground", FarGroundParameters)))
        if self.colour_model not in ("log_rgb", "hsi"):
            raise InvalidInputError(f"colour_model must be 'log_rgb' or 'hsi', got {self.colour_model!r}")
        if not isinstance(self.shadow_rule, bool):
            raise InvalidInputError(f"shadow_rule must be a bool, got {self.shadow_rule!r}")
        check_numbers(self, (("shadow_min_ratio", 0.0, 1.0), ("shadow_max_ratio", 0.0, 1.0)))
        if not 0.0 < self.shadow_min_ratio < self.shadow_max_ratio < 1.0:
            raise InvalidInputError("need 0 < shadow_min_ratio < shadow_max_ratio < 1, got "
                                    f"{self.shadow_min_ratio!r} and {self.shadow_max_ratio!r}")
        check_numbers(self, (("shadow_blue_shift", 0.0, math.inf), ("veto_factor", 1.0, math.inf),
                             ("shadow_chroma_band", 1.0, math.inf), ("max_hole_fraction", 0.0, 1.0),
                             ("ground_intensity_margin", 0.0, math.inf)))
        check_integers(self, (("min_obstacle_area_px", 0, math.inf), ("max_hole_area_px", 0, math.inf),
                              ("intensity_smoothing_px", 0, math.inf)))
        check_integers(self, (("filter_size", 1, math.inf),), odd=True)


@dataclass(frozen=True, eq=False)
class SegmentationResult:
    """Output of :func:`segment`.

    Attributes
    ----------
    labels
        ``uint8 (H, W)`` of :class:`~stereo_obstacles.labels.Label` values GROUND, SHADOW,
        OBSTACLE, UNKNOWN.
    reference
        The ground statistics the labels were computed from.
    params
        The parameters used.
    ground_check
        The stereo cue (ground plane and off-ground pixels) when the right image was given and
        the plane could be estimated; None otherwise.
    textureless_shadow
        ``bool (H, W)``: the shadow pixels the shadow texture test made obstacles; None when
        the test was not made (off, no shadow rule, or a reference area without texture).
    """

    labels: np.ndarray
    reference: ReferenceStatistics
    params: SegmentationParameters
    ground_check: GroundCheck | None = None
    textureless_shadow: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.labels.dtype != np.uint8 or self.labels.ndim != 2:
            raise InvalidInputError(f"labels must be uint8 (H, W), got {self.labels.dtype} {self.labels.shape}")

    @property
    def obstacle_mask(self) -> np.ndarray:
        """``bool (H, W)``: pixels labelled OBSTACLE."""
        return self.labels == Label.OBSTACLE.value

    @property
    def ground_mask(self) -> np.ndarray:
        """``bool (H, W)``: pixels labelled GROUND or SHADOW (ground in shadow)."""
        return (self.labels == Label.GROUND.value) | (self.labels == Label.SHADOW.value)


def _match_flags(rgb: np.ndarray, inv_full_scale: float, ref: ReferenceStatistics,
                 params: SegmentationParameters) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    shape = rgb.shape[:2]
    flags = np.empty(shape + (4,), dtype=np.uint8)
    veto = np.empty(shape, dtype=np.bool_)
    intensity = np.empty(shape, dtype=np.float32)
    ref_x = ref_y = cos_ground = cos_veto = max_sat_ground = max_sat_veto = 0.0
    if ref.is_grey:
        max_sat_ground = ref.max_saturation
        max_sat_veto = params.veto_factor * ref.max_saturation
    else:
        angle = math.radians(ref.hue_deg)
        ref_x, ref_y = math.cos(angle), math.sin(angle)
        cos_ground = math.cos(math.radians(ref.hue_threshold_deg))
        cos_veto = math.cos(math.radians(min(180.0, params.veto_factor * ref.hue_threshold_deg)))
    full_scale = 1.0 / inv_full_scale
    ref_rgb = np.array(ref.rgb_median, dtype=np.float64) * full_scale
    match_flags_kernel(rgb, inv_full_scale, np.float32(params.min_intensity),
                       np.float32(params.min_saturation), ref.is_grey, np.float32(ref_x),
                       np.float32(ref_y), np.float32(cos_ground), np.float32(cos_veto),
                       np.float32(max_sat_ground), np.float32(max_sat_veto), ref_rgb,
                       float(params.shadow_blue_shift), float(params.shadow_chroma_band), flags,
                       veto, intensity)
    return flags, veto, intensity


def _window_sizes(height: int, width: int, size: int) -> np.ndarray:
    """Number of image pixels in the ``size x size`` window around each pixel, ``int32``."""
    r = size // 2

    def along(n: int) -> np.ndarray:
        i = np.arange(n)
        return np.minimum(i + r, n - 1) - np.maximum(i - r, 0) + 1

    return np.outer(along(height), along(width)).astype(np.int32)


def _remove_specks(labels: np.ndarray, darker: np.ndarray | None, params: SegmentationParameters) -> None:
    """Obstacle regions smaller than ``params.min_obstacle_area_px`` become ground, or shadow
    where ``darker`` (``bool (H, W)``) is set, in place."""
    if params.min_obstacle_area_px > 1:
        obstacle = (labels == Label.OBSTACLE.value).view(np.uint8)
        n, components = cv2.connectedComponents(obstacle, connectivity=8, ltype=cv2.CV_32S)
        if darker is None or not params.shadow_rule:
            darker = np.zeros(labels.shape, dtype=np.bool_)
        fill_small_components_kernel(components, n, params.min_obstacle_area_px, darker,
                                     int(Label.GROUND), int(Label.SHADOW), labels)


def segment(rgb: np.ndarray, *, right: np.ndarray | None = None,
            reference: ReferenceArea = DEFAULT_REFERENCE_AREA,
            params: SegmentationParameters = SegmentationParameters()) -> SegmentationResult:
    """Label every pixel as ground, ground in shadow, obstacle or unknown.

    Parameters
    ----------
    rgb
        ``uint8`` or ``uint16`` ``(H, W, 3)`` RGB image (the left one of a rectified pair).
    right
        Optional right image of the rectified pair, same size and dtype: adds the stereo cue
        (pixels off the ground plane become obstacles, :mod:`~stereo_obstacles.ground_check`).
        Nothing above the plane's horizon is ground. When the plane cannot be estimated from
        the reference area, it is estimated from a taller band (a warning is logged); when that
        fails too, a warning is logged and the colour labels are returned (``ground_check``
        None).
    reference
        The rectangle assumed to be ground (default: the full-width bottom 15 %,
        :data:`~stereo_obstacles.reference_area.DEFAULT_REFERENCE_AREA`).
    params
        Thresholds; see :class:`SegmentationParameters`.

    Returns
    -------
    SegmentationResult
        ``uint8 (H, W)`` labels and the reference statistics used.

    Raises
    ------
    InvalidInputError
        Bad image, or an unusable reference area (too dark, or not one ground).
    ImageMismatchError
        ``right`` differs from ``rgb`` in size or dtype.

    Examples
    --------
    >>> import numpy as np
    >>> ground = np.random.default_rng(0).normal((90, 140, 60), 3, (60, 80, 3))  # green ground
    >>> ground[40:50, 5:25] *= (0.57, 0.625, 0.71)  # a shadow: darker and bluer (skylight)
    >>> image = np.clip(ground, 0, 255).astype(np.uint8)
    >>> image[10:30, 30:40] = (200, 40, 40)       # a red box
    >>> labels = segment(image).labels
    >>> [int(labels[20, 35]), int(labels[45, 15]), int(labels[55, 40])]
    [3, 2, 1]
    """
    a, inv_full_scale = check_rgb(rgb)
    b = None
    if right is not None:
        a, b = check_colour_pair(a, right)
    if not isinstance(reference, ReferenceArea):
        raise InvalidInputError(f"reference must be a ReferenceArea, got {type(reference).__name__}")
    if not isinstance(params, SegmentationParameters):
        raise InvalidInputError(f"params must be SegmentationParameters, got {type(params).__name__}")
    box = reference.to_pixels(a.shape[0], a.shape[1])
    # two tasks at once on the two cores (the kernels and OpenCV release the GIL): the colour
    # labels beside the texture map, or (longer) the colour labels and the texture test beside
    # the stereo cue and the far rows' colours
    if b is None:
        (ref, labels), smooth = run_each_in_threads([(_reference_and_colour_labels, a, inv_full_scale, box, params),
                                                     (_smooth_pixels, a, box, params)])
        smooth_shadow = _mark_textureless_shadow(labels, smooth, params)
        ground = far = None
    else:
        (ref, labels, smooth_shadow), (ground, far, skipped) = run_each_in_threads([
            (_colour_cues, a, inv_full_scale, box, params),
            (_stereo_cues, a, b, box, params)])
        # logged only now, so that an unusable reference area (raised above) comes without them
        if skipped is not None:
            logger.warning("stereo ground check skipped, colour labels only: %s", skipped)
        elif ground.fallback_reason is not None:
            logger.warning("stereo ground check: %s; the plane was estimated from the taller band %s instead",
                           ground.fallback_reason, ground.plane_box)
    if ground is not None:
        labels[ground.off_ground] = Label.OBSTACLE
        # no ground is seen above the horizon: what colour took for ground there stands up from it
        labels[ground.above_horizon & ((labels == Label.GROUND.value) | (labels == Label.SHADOW.value))] = Label.OBSTACLE
    _fill_holes(labels, params)
    if ground is not None:
        labels[far_ground_pixels(far, labels == Label.OBSTACLE.value) & ~ground.above_horizon] = Label.GROUND
    if smooth_shadow is not None:
        smooth_shadow &= labels == Label.OBSTACLE.value          # what the texture test made obstacle and still is
    logger.debug("segmented %dx%d: %.1f %% obstacle", a.shape[1], a.shape[0],
                 100.0 * np.count_nonzero(labels == Label.OBSTACLE.value) / labels.size)
    return SegmentationResult(labels=labels, reference=ref, params=params, ground_check=ground,
                              textureless_shadow=smooth_shadow)


def _fill_holes(labels: np.ndarray, params: SegmentationParameters) -> None:
    """Holes become obstacle, in place: non-obstacle regions (4-connected) smaller than
    ``params.max_hole_area_px``, and those not touching the image border of at most
    ``params.max_hole_fraction`` of the image. One labelling serves both rules."""
    max_enclosed = int(params.max_hole_fraction * labels.size)
    if params.max_hole_area_px <= 1 and max_enclosed < 1:
        return
    free = (labels != Label.OBSTACLE.value).view(np.uint8)
    n, components = cv2.connectedComponents(free, connectivity=4, ltype=cv2.CV_32S)
    fill_holes_kernel(components, n, params.max_hole_area_px, max_enclosed, int(Label.OBSTACLE), labels)


def _colour_labels(a: np.ndarray, inv_full_scale: float, ref: ReferenceStatistics,
                   box: tuple[int, int, int, int], params: SegmentationParameters) -> np.ndarray:
    """``uint8 (H, W)`` labels of the chosen colour model, cleaned up."""
    if params.colour_model == "hsi":
        return _hsi_labels(a, inv_full_scale, ref, params)
    return _log_rgb_labels(a, box, params)


def _reference(a: np.ndarray, box: tuple[int, int, int, int], params: SegmentationParameters) -> ReferenceStatistics:
    """The reference area's statistics, from a sample of its pixels (raises when it is unusable)."""
    x0, y0, x1, y1 = box
    step = params.reference.sample_step(y1 - y0, x1 - x0)
    area = a[y0:y1:step, x0:x1:step]
    area_hsi = rgb_to_hsi(area, min_intensity=params.min_intensity, min_saturation=params.min_saturation)
    return reference_statistics(area, area_hsi, box, params=params.reference)


def _reference_and_colour_labels(a: np.ndarray, inv_full_scale: float, box: tuple[int, int, int, int],
                                 params: SegmentationParameters) -> tuple[ReferenceStatistics, np.ndarray]:
    """:func:`_reference`, then :func:`_colour_labels` with it."""
    ref = _reference(a, box, params)
    return ref, _colour_labels(a, inv_full_scale, ref, box, params)


def _colour_cues(a: np.ndarray, inv_full_scale: float, box: tuple[int, int, int, int],
                 params: SegmentationParameters) -> tuple[ReferenceStatistics, np.ndarray, np.ndarray | None]:
    """:func:`_reference_and_colour_labels`, then the texture test on those labels: the reference
    statistics, the labels (textureless shadow made obstacle) and the textureless shadow mask."""
    smooth = _smooth_pixels(a, box, params)
    ref, labels = _reference_and_colour_labels(a, inv_full_scale, box, params)
    return ref, labels, _mark_textureless_shadow(labels, smooth, params)


def _mark_textureless_shadow(labels: np.ndarray, smooth: np.ndarray | None,
                             params: SegmentationParameters) -> np.ndarray | None:
    """Shadow pixels too smooth to be ground in shadow become obstacle, in place; returns them
    (``bool (H, W)``), or None when the texture test is not made (``smooth`` None)."""
    if smooth is None:
        return None
    flagged = textureless_shadow(smooth, labels == Label.SHADOW.value, params=params.shadow_texture)
    labels[flagged] = Label.OBSTACLE
    return flagged


def _smooth_pixels(a: np.ndarray, box: tuple[int, int, int, int], params: SegmentationParameters) -> np.ndarray | None:
    """The shadow texture test's smooth pixels (``bool (H, W)``), or None when it is not made."""
    if not params.shadow_rule:
        return None
    return smooth_pixels(grey_levels(a), box, params=params.shadow_texture)


def _stereo_cues(left: np.ndarray, right: np.ndarray, box: tuple[int, int, int, int],
                 params: SegmentationParameters) -> tuple[GroundCheck | None, FarGroundRows | None, str | None]:
    """The stereo ground check and the far rows' ground-coloured pixels, or (None, None, why)
    when the plane cannot be estimated from the reference area ``box`` (the caller logs why);
    the images were validated by the caller."""
    try:
        ground = check_ground(left, right, box, params=params.ground_check)
    except InvalidInputError as error:
        return None, None, str(error)
    return ground, far_ground_rows(left, ground.off_ground, ground.plane, box, params=params.far_ground), None


def _hsi_labels(a: np.ndarray, inv_full_scale: float, ref: ReferenceStatistics,
                params: SegmentationParameters) -> np.ndarray:
    flags, veto, intensity = _match_flags(a, inv_full_scale, ref, params)
    counts = window_counts(flags, size=params.filter_size)
    ground_low = max(0.0, ref.intensity_low - params.ground_intensity_margin)
    ground_high = ref.intensity_high + params.ground_intensity_margin
    if params.intensity_smoothing_px > 1:
        k = params.intensity_smoothing_px
        intensity = cv2.blur(intensity, (k, k), borderType=cv2.BORDER_REFLECT)
    labels = np.empty(a.shape[:2], dtype=np.uint8)
    median = ref.intensity_median
    classify_kernel(counts, _window_sizes(a.shape[0], a.shape[1], params.filter_size), veto,
                    intensity, np.float32(params.min_intensity),
                    np.float32(ground_low), np.float32(ground_high),
                    np.float32(params.shadow_min_ratio * median),
                    np.float32(params.shadow_max_ratio * median),
                    np.float32(median / params.shadow_max_ratio),
                    np.float32(median / params.shadow_min_ratio), params.shadow_rule,
                    int(Label.UNKNOWN), int(Label.GROUND), int(Label.SHADOW), int(Label.OBSTACLE),
                    labels)
    _remove_specks(labels, intensity < ground_low, params)
    return labels


def _log_rgb_labels(a: np.ndarray, box: tuple[int, int, int, int],
                    params: SegmentationParameters) -> np.ndarray:
    shadow_ratio = (params.shadow_min_ratio, params.shadow_max_ratio) if params.shadow_rule else None
    model = build_ground_colour_model(a, box, params=params.ground_colour, shadow_ratio=shadow_ratio)
    if model.n_ground_cells == 0:
        logger.warning("reference area %s: no colour is shared by %d of its %d strips; everything "
                       "will be called obstacle", box, params.ground_colour.quorum,
                       params.ground_colour.n_strips)
    flags, veto = colour_flags(a, model, params.min_intensity)
    counts = window_counts(flags, size=params.filter_size)
    labels = np.empty(a.shape[:2], dtype=np.uint8)
    classify_modes_kernel(counts, veto, flags[..., 3], int(Label.UNKNOWN), int(Label.GROUND),
                          int(Label.SHADOW), int(Label.OBSTACLE), labels)
    _remove_specks(labels, None, params)
    return labels


__all__ = ["SegmentationParameters", "SegmentationResult", "segment"]
