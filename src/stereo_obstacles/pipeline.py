"""The whole system: two rectified colour images in, obstacles with distances out.

This module only wires the stages; each lives in its own module:

1. :func:`stereo_obstacles.segmentation.segment` — phase 1, ground / shadow / obstacle labels;
2. :func:`stereo_obstacles.matching.match` — phase 2, GCS disparity;
3. :func:`stereo_obstacles.ground_plane.fit_ground_plane` on the ground pixels' disparities,
   :func:`stereo_obstacles.depth.disparity_to_depth`, then
   :func:`stereo_obstacles.obstacle_grouping.group_obstacle_pixels` and
   :func:`stereo_obstacles.obstacles.measure_obstacles` — phase 3, obstacles as objects.

Beyond the paper:

* pixels that phase 1 calls ground but whose disparity puts them clearly above the fitted
  ground plane (``geometric_min_height_m``) are obstacle candidates too: a dark object of the
  ground's hue would otherwise pass for a shadow;
* with a calibration, a pixel stands above the ground plane only when its disparity exceeds the
  plane's by three times its own uncertainty, estimated from the pair's noise and the texture
  of its window (:mod:`stereo_obstacles.disparity_uncertainty`): patches of noisy far ground
  matched a pixel too near are not obstacles;
* islands of matches that took a repeat of the texture around them, one period too far (a
  wall, a fence, paving), are removed (:mod:`stereo_obstacles.repeated_texture`): they stand in
  front of the surface as phantoms;
* matches the right camera cannot see (half-occluded background beside the left edge of a
  near object, matched anyway to the near object's texture) are removed first
  (:mod:`stereo_obstacles.visibility`): they put phantom surfaces between two depths;
* a group made mostly of ground-coloured matches in the strip of ground beside a near object's
  left edge that the right camera cannot see is rejected (:mod:`stereo_obstacles.hidden_ground`):
  such matches put a phantom between the two depths when the near object's first columns went
  unmatched;
* candidates standing above the ground plane are grouped into obstacles, and the flat ones
  separately, only to report them as rejected (markings, puddles): grouping them together
  would chain distinct objects through the ground between them;
* a group holding two colours at two depths (a pole just in front of a box) is split along
  the colours (:mod:`stereo_obstacles.colour_split`);
* the standing pixels no group took that lie behind the groups beside them and stand on the
  ground (a farther object's strip beside a nearer one) become a group
  (:mod:`stereo_obstacles.leftover_groups`);
* an obstacle's pixels coloured like a farther obstacle beside them, that farther object's edge
  carrying the nearer one's disparity, are taken out of it (:mod:`stereo_obstacles.fattened_fringes`);
* a strip of another colour in an obstacle that matches farther with windows weighted to its own
  colour (a farther object seen in a sliver beside the nearer one) is re-matched there and leaves
  it, an obstacle of its own when large enough (:mod:`stereo_obstacles.own_colour_matching`);
* faces too flat to match (dark paint), which phase 1 calls obstacle but the matcher leaves
  empty but for their outlines, are filled from those outlines when they stand on the ground at
  their depth (:mod:`stereo_obstacles.textureless_fill`), for the free range per direction and
  the obstacles' boxes, lateral extents and widths; two obstacles that are the outlines of one
  such face are joined into one (:mod:`stereo_obstacles.face_joining`);
* obstacles of one colour whose footprints on the ground touch, or of any colours whose
  footprints coincide (compared by each column's span of depths), are pieces of one object (a
  pole's top above a nearer box and its foot below it, a wall's sunlit top face and its front
  face) and are joined into one (:mod:`stereo_obstacles.footprint_joining`);
* when the pixels that look like the reference area do not lie on a plane that can be the
  ground (the reference area is covered by a wall or a large object), the ground plane is
  fitted to the matched pixels of the lower third of the image instead, the colour labels are
  not trusted, and obstacles are found from geometry alone, with a warning.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, replace
from functools import partial
from types import MappingProxyType

import cv2
import numpy as np

from stereo_obstacles.blind_strip import BlindStripParameters, extend_into_blind_strip
from stereo_obstacles.calibration import StereoCalibration, sized_for_images
from stereo_obstacles.camera_calibration import CameraPairCalibration
from stereo_obstacles.colour_split import ColourCue, colour_cue
from stereo_obstacles.depth import disparity_to_depth
from stereo_obstacles.disparity_uncertainty import disparity_sigma_px, pair_noise_sigma
from stereo_obstacles.errors import CalibrationError, ImageMismatchError, InvalidInputError
from stereo_obstacles.face_joining import FaceJoiningParameters, obstacles_sharing_a_face
from stereo_obstacles.fattened_fringes import FringeParameters, fattened_fringes
from stereo_obstacles.field_checks import (check_integers, check_numbers, check_positive, check_types, plain_number,
                                           plain_numbers)
from stereo_obstacles.footprint_joining import FootprintJoiningParameters, pieces_of_one_object
from stereo_obstacles.image_pairs import check_same_size
from stereo_obstacles.fileio import to_uint8
from stereo_obstacles.labels import Label
from stereo_obstacles.leftover_groups import LeftoverParameters, leftover_groups
from stereo_obstacles.matching import MIN_SIZE, check_match_options, disparity_range, warn_if_range_cut_off
from stereo_obstacles.obstacle_grouping import GroupingParameters, group_obstacle_pixels
from stereo_obstacles.obstacle_joining import measure_joined
from stereo_obstacles.ground_plane import GroundPlane, fit_ground_plane, raised_pixels, tilt_from_camera_vertical_deg
from stereo_obstacles.hidden_ground import HiddenGroundParameters, reject_hidden_ground
from stereo_obstacles.obstacles import (Obstacle, ObstacleList, ObstacleParameters, RejectedGroup, list_obstacles,
                                        measure_groups, measure_without, obstacle_scan, standing_pixels)
from stereo_obstacles.own_colour_matching import OwnColourParameters, compile_cover, moved_groups, own_colour_matches
from stereo_obstacles.rectification_check import RectificationCheck, check_rectification
from stereo_obstacles.reference_area import DEFAULT_REFERENCE_AREA, ReferenceArea
from stereo_obstacles.repeated_texture import RepeatedTextureParameters, repeat_islands
from stereo_obstacles.scaled_matching import check_scale, match_at_scale, refine_at_full_size, warn_if_scale_raised
from stereo_obstacles.segmentation import SegmentationParameters, SegmentationResult, segment
from stereo_obstacles.similarity import to_grey
from stereo_obstacles.textureless_fill import (BracketedRuns, TexturelessFillParameters, bracketed_runs,
                                               paint_runs, textureless_candidates, widen_obstacles)
from stereo_obstacles.thread_pool import run_each_in_threads
from stereo_obstacles.visibility import VisibilityParameters, hidden_in_right

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class MatchingOptions:
    """Options passed to :func:`stereo_obstacles.matching.match`; ``None`` keeps its default
    (in the obstacle pipeline: :data:`PIPELINE_MATCHING` first)."""

    seeds: str | None = None
    max_disparity: int | None = None
    tau: float | None = None
    mu: float | None = None
    max_candidates: int | None = None
    variant: str | None = None
    speckle_size: int | None = None
    speckle_range: float | None = None

    def __post_init__(self) -> None:
        plain_numbers(self)                      # NumPy scalars as Python numbers (JSON-ready)
        if self.max_disparity is not None:
            check_integers(self, (("max_disparity", 1, math.inf),))
        check_match_options(**self.to_kwargs())      # when made, not at the first frame (API review)

    def to_kwargs(self) -> dict:
        """Keyword arguments for ``match`` with the unset options left out."""
        return {k: v for k, v in asdict(self).items() if v is not None}


DEFAULT_MATCHING_SCALE = 0.5
""":attr:`DetectionConfig.matching_scale` unless given: found as many obstacles as 1, in about
three quarters of the matching time (``docs/pipeline.md``, "Matching scale")."""

PIPELINE_MATCHING = {"speckle_size": 0}
"""The obstacle pipeline's own defaults for :func:`~stereo_obstacles.matching.match` options
that :class:`MatchingOptions` leaves unset: no speckle removal. With it, the half-size match
lost a 3 613 px box of scene 1 (``docs/matching.md``, "Speckle removal"); the matcher's other
session-10 defaults (``mu`` 0.05, ``max_candidates`` 4) gave the same detection figures
(``docs/pipeline.md``, session 10)."""


def pipeline_match_kwargs(options: MatchingOptions) -> dict:
    """Keyword arguments the obstacle pipeline passes to ``match``: :data:`PIPELINE_MATCHING`,
    overridden by the options set in ``options``."""
    return {**PIPELINE_MATCHING, **options.to_kwargs()}


@dataclass(frozen=True)
class DetectionConfig:
    """Every option of the pipeline, grouped by stage; saved next to every output.

    The stages' own options: ``reference`` (the area taken for ground), ``segmentation``
    (phase 1), ``matching`` (phase 2: ``max_disparity``, ``seeds``, ...), ``grouping`` and
    ``obstacles`` (phase 3: ``max_distance_m``, ``corridor_width_m``, ...); change one with
    :func:`dataclasses.replace`, e.g. ``replace(config, obstacles=replace(config.obstacles,
    max_distance_m=10.0))``.

    ``geometric_min_height_m``: ground-labelled pixels this far above the ground plane become
    obstacle candidates (needs a calibration; ``0`` switches it off), if their disparity also
    exceeds the plane's by ``geometric_min_excess_px`` (full-size pixels).
    ``check_rectification``: match ORB features first and warn when the pair does not look
    rectified (a stream can check its first frame only).
    ``matching_scale``: grow the correspondence seeds on a copy of the pair shrunk by this
    factor in ``(0, 1]`` and refine the matches on the full-size pair
    (:mod:`stereo_obstacles.scaled_matching`). The default 0.5 found as many obstacles as 1 with
    the same distance errors and no false alarm, in about three quarters of the matching time
    (``docs/pipeline.md``, "Matching scale"); 1 grows at full size. Segmentation and obstacles
    are always at full size. Images with a side under 240 pixels are matched at a larger scale
    (:func:`stereo_obstacles.scaled_matching.effective_scale`); for a scale other than the
    default, with a warning.
    ``visibility``: matches the right camera cannot see (half-occluded pixels beside the left
    edge of a near object, matched anyway) are removed from the disparity before anything uses
    it (:mod:`stereo_obstacles.visibility`); ``None`` keeps them.
    ``repeated_texture``: islands of matches standing in front of the surface around them that
    also match well at its disparity (NCC 0.8 or more), and not between the two (a patch of a
    wall, fence or paving matched to a repeat of its texture, one period too far), are removed
    before the visibility test, which would trust them (:mod:`stereo_obstacles.repeated_texture`); ``None`` keeps them.
    ``blind_strip``: obstacles reaching the strip at the left border that only the left camera
    sees are continued into it for their measurement (:mod:`stereo_obstacles.blind_strip`);
    ``None`` switches that off.
    ``standing_significance``: with a calibration and a ground plane, a pixel stands above the
    plane (an obstacle candidate of ground colour, or a standing obstacle pixel) only when its
    disparity also exceeds the plane's by this many times its own disparity uncertainty,
    estimated from the pair's noise and its window's texture
    (:mod:`stereo_obstacles.disparity_uncertainty`), the uncertainty taken as at most
    ``standing_max_sigma_px`` (full-size pixels); ``None`` switches the test off. It keeps noisy
    or compressed images from raising patches of far ground as obstacles (``docs/pipeline.md``,
    "Noise and compression"); groups it keeps down are listed as rejected.
    ``textureless_fill``: with a calibration, a ground plane and trusted colour labels, the
    textureless faces the matcher left empty are filled from their outlines
    (:mod:`stereo_obstacles.textureless_fill`): the free range per direction is measured with
    them, and the obstacles' boxes, lateral extents and widths take them in (their distances do not);
    ``None`` uses the matched pixels only.
    ``face_joining``: where the textureless fill runs, two obstacles that are the outlines of
    one textureless face (the ends of its bracketed rows) are joined into one
    (:mod:`stereo_obstacles.face_joining`); ``None`` keeps them apart, and so does
    ``textureless_fill=None``, whose rows it reads.
    ``footprint_joining``: with a calibration and the colour split's colour cue, obstacles of one
    colour whose footprints on the ground plan touch, and obstacles of any colours whose
    footprints coincide, are pieces of one object and are joined into one
    (:mod:`stereo_obstacles.footprint_joining`); ``None`` keeps them apart. An
    obstacle joined from pieces, by either joining, is measured as one, its distance kept no
    farther than its largest piece's (:mod:`stereo_obstacles.obstacle_joining`).
    ``hidden_ground``: with a calibration, a ground plane and trusted colour labels, a group of
    obstacle pixels made mostly of ground-coloured matches that, were they ground, the right
    camera could not see behind a nearer object's left edge is rejected, with its reason
    (:mod:`stereo_obstacles.hidden_ground`); ``None`` keeps such groups.
    ``fattened_fringes``: with the colour split's colour cue, an obstacle's pixels coloured like
    a farther obstacle beside them (its edge, carrying the nearer one's disparity by the
    matching's fattening) are taken out of it before the joinings, and the groups that lost them
    measured again (:mod:`stereo_obstacles.fattened_fringes`); ``None`` keeps them.
    ``own_colour``: with the colour cue, the strips of another colour in an obstacle that match
    farther with windows weighted to their own colour are re-matched there (in the delivered
    disparity and depth too), taken out of the obstacle and grouped on their own
    (:mod:`stereo_obstacles.own_colour_matching`); ``None`` keeps them as matched. It mends slivers
    of a farther object beside a nearer one, for a median 5 ms a 640 x 480 pair and 75 ms on KITTI
    000005, whose many objects of several colours hold some 200 such pieces (``docs/pipeline.md``,
    sessions 40-41).
    ``leftover``: with a calibration and a ground plane, the standing pixels of phase-1 obstacle
    colour that no group took (a farther object's strip beside a nearer one, in cells the nearer
    one holds) become a group when they hold an object's pixel count, lie behind every group
    beside them and stand on the ground (:mod:`stereo_obstacles.leftover_groups`); ``None``
    leaves them out.
    """

    reference: ReferenceArea = DEFAULT_REFERENCE_AREA
    segmentation: SegmentationParameters = field(default_factory=SegmentationParameters)
    matching: MatchingOptions = field(default_factory=MatchingOptions)
    grouping: GroupingParameters = field(default_factory=GroupingParameters)
    obstacles: ObstacleParameters = field(default_factory=ObstacleParameters)
    geometric_min_height_m: float = 0.15
    check_rectification: bool = True
    matching_scale: float = DEFAULT_MATCHING_SCALE
    geometric_min_excess_px: float = 0.5
    blind_strip: BlindStripParameters | None = field(default_factory=BlindStripParameters)
    visibility: VisibilityParameters | None = field(default_factory=VisibilityParameters)
    repeated_texture: RepeatedTextureParameters | None = field(default_factory=RepeatedTextureParameters)
    standing_significance: float | None = 3.0
    standing_max_sigma_px: float = 0.75
    textureless_fill: TexturelessFillParameters | None = field(default_factory=TexturelessFillParameters)
    hidden_ground: HiddenGroundParameters | None = field(default_factory=HiddenGroundParameters)
    face_joining: FaceJoiningParameters | None = field(default_factory=FaceJoiningParameters)
    footprint_joining: FootprintJoiningParameters | None = field(default_factory=FootprintJoiningParameters)
    fattened_fringes: FringeParameters | None = field(default_factory=FringeParameters)
    own_colour: OwnColourParameters | None = field(default_factory=OwnColourParameters)
    leftover: LeftoverParameters | None = field(default_factory=LeftoverParameters)

    def __post_init__(self) -> None:
        # a dict or None for a stage's options failed later with AttributeError (API review, session 23)
        check_types(self, (("reference", ReferenceArea), ("segmentation", SegmentationParameters),
                           ("matching", MatchingOptions), ("grouping", GroupingParameters),
                           ("obstacles", ObstacleParameters), ("check_rectification", bool)))
        check_types(self, (("blind_strip", BlindStripParameters), ("visibility", VisibilityParameters),
                           ("repeated_texture", RepeatedTextureParameters),
                           ("textureless_fill", TexturelessFillParameters),
                           ("hidden_ground", HiddenGroundParameters), ("face_joining", FaceJoiningParameters),
                           ("footprint_joining", FootprintJoiningParameters),
                           ("fattened_fringes", FringeParameters), ("own_colour", OwnColourParameters),
                           ("leftover", LeftoverParameters)),
                    allow_none=True)
        check_numbers(self, (("geometric_min_height_m", 0.0, math.inf), ("geometric_min_excess_px", 0.0, math.inf)))
        check_scale(plain_number(self, "matching_scale"))
        if self.standing_significance is not None:
            check_numbers(self, (("standing_significance", 0.0, math.inf),))
        check_positive(self, ("standing_max_sigma_px",))

    def to_dict(self) -> dict:
        """JSON-ready nested mapping of every option; ``matching`` shows the pipeline's own
        defaults (:data:`PIPELINE_MATCHING`) where they apply, not ``None``."""
        options = asdict(self)
        options["matching"].update(pipeline_match_kwargs(self.matching))
        return options


@dataclass(frozen=True, eq=False)
class DetectionResult:
    """Everything the pipeline computed for one pair.

    Attributes
    ----------
    segmentation
        Phase-1 result (``labels`` uint8 (H, W)).
    disparity
        ``float32 (H, W)`` left disparity in pixels, NaN where unmatched.
    match_stats
        Statistics of the matcher (:class:`stereo_obstacles.matching.MatchStats`): of the
        reduced pair when the pair was matched at a scale below 1
        (:func:`stereo_obstacles.scaled_matching.effective_scale`), of the refinement alone when
        a ``disparity_estimate`` was refined. :attr:`density` is that of ``disparity``.
    depth_m
        ``float32 (H, W)`` depth in metres, NaN where unknown; ``None`` without calibration.
    ground
        The ground plane in disparity space; ``None`` when too few ground pixels matched, or
        when no plane fitted to them can be the ground (with a calibration: tilted more than
        ``MAX_GROUND_TILT_DEG`` from the camera's vertical, a wall).
    obstacles
        Obstacles nearest first, rejected groups, corridor summary.
    calibration
        The calibration used, or ``None`` (then lengths are not known).
    config
        The resolved configuration.
    timings_s
        Wall seconds of each stage (``segmentation``: phase 1 and the colour cue of the
        grouping; ``rectification_check``, ``matching``, ``obstacles``) and in ``total``; the
        first two run on a second thread beside the matching, so the stages add up to more than
        the total. A read-only mapping (``dict(result.timings_s)`` for a copy).
    rectification_check
        :class:`stereo_obstacles.rectification_check.RectificationCheck` of the input pair
        (a warning is logged when it is not rectified).

    The result is frozen: its fields cannot be reassigned, its timings cannot be changed, and
    its images (``disparity``, ``depth_m``, the labels, the obstacles' ``id_map``) are read-only
    views, so that what a caller hands on stays consistent with the obstacles measured from it
    (copy an array to change it; the arrays a result is made from stay writeable).
    """

    segmentation: SegmentationResult
    disparity: np.ndarray
    match_stats: object
    depth_m: np.ndarray | None
    ground: GroundPlane | None
    obstacles: ObstacleList
    calibration: StereoCalibration | None
    config: DetectionConfig
    timings_s: Mapping[str, float]
    rectification_check: object = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "disparity", _read_only(self.disparity))
        object.__setattr__(self, "depth_m", None if self.depth_m is None else _read_only(self.depth_m))
        object.__setattr__(self, "segmentation", replace(self.segmentation,
                                                         labels=_read_only(self.segmentation.labels)))
        object.__setattr__(self, "obstacles", replace(self.obstacles, id_map=_read_only(self.obstacles.id_map)))
        object.__setattr__(self, "timings_s", MappingProxyType(dict(self.timings_s)))

    @property
    def density(self) -> float:
        """Share of the image's pixels with a disparity in :attr:`disparity` (the delivered,
        full-size map; ``match_stats.density`` counts the matcher's own, possibly reduced, pair)."""
        return float(np.count_nonzero(np.isfinite(self.disparity))) / self.disparity.size


def _read_only(image: np.ndarray) -> np.ndarray:
    """A read-only view of ``image`` (the array itself stays writeable)."""
    view = np.asarray(image).view()
    view.flags.writeable = False
    return view


def _check_inputs(left: np.ndarray, right: np.ndarray, calibration, config) -> None:
    if not isinstance(config, DetectionConfig):
        raise InvalidInputError(f"config must be a DetectionConfig, got {type(config).__name__}")
    for name, image in (("left", left), ("right", right)):
        if not isinstance(image, np.ndarray) or image.ndim != 3 or image.shape[2] != 3:
            raise InvalidInputError(f"{name} must be an RGB (H, W, 3) image, got "
                                    f"{getattr(image, 'shape', type(image).__name__)}")
        if image.dtype not in (np.uint8, np.uint16):
            hint = " (an image scaled to 0..1: multiply by 255 and convert)" if image.dtype.kind == "f" else ""
            raise InvalidInputError(f"{name} must be uint8 or uint16, got {image.dtype}{hint}")
    check_same_size(left, right)
    if min(left.shape[:2]) < MIN_SIZE:
        raise InvalidInputError(f"images must be at least {MIN_SIZE}x{MIN_SIZE} pixels (one correlation window), got "
                                f"{left.shape[1]}x{left.shape[0]}")
    if calibration is not None and not isinstance(calibration, StereoCalibration):
        hint = (": the two cameras before rectification; rectify them first "
                "(stereo_obstacles.rectification.rectify_calibration(...).rectified, with .apply for the images)"
                if isinstance(calibration, CameraPairCalibration) else "")
        raise CalibrationError(f"calibration must be a StereoCalibration (a rectified pair) or None, got "
                               f"{type(calibration).__name__}{hint}")


def _check_hints(seed_points, disparity_estimate, shape: tuple[int, int], config: DetectionConfig) -> None:
    """Refuse seed points or a disparity estimate :func:`detect` cannot use: both given, seeds not
    ``(N, 3)`` finite numbers, an estimate of another shape or outside the disparity range searched
    (a wrong estimate made phantom obstacles: 1e6 px read 0.31 m)."""
    if seed_points is not None and disparity_estimate is not None:
        raise InvalidInputError("seed_points and disparity_estimate: give one or the other")
    if seed_points is not None:
        points = np.asarray(seed_points)
        if points.ndim != 2 or points.shape[1] != 3 or points.dtype.kind not in "iuf":
            raise InvalidInputError(f"seed_points must be (N, 3) numbers (x, y, d), got {points.dtype} {points.shape}")
        if not np.isfinite(points).all():
            raise InvalidInputError("seed_points: contains NaN or infinite values")
    if disparity_estimate is not None:
        if np.shape(disparity_estimate) != shape:
            raise ImageMismatchError(f"disparity_estimate must have the images' shape {shape}, got "
                                     f"{np.shape(disparity_estimate)}")
        estimate = np.asarray(disparity_estimate)          # no copy: a stream refines every other frame
        d_max = disparity_range(shape[1], 0, config.matching.max_disparity)[1]
        with np.errstate(invalid="ignore"):
            outside = (estimate < 0) | (estimate > d_max)                                # NaN: no estimate
        if outside.any():
            raise InvalidInputError(f"disparity_estimate: {int(outside.sum())} values lie outside the disparity range "
                                    f"[0, {d_max}] px searched (NaN marks a pixel without an estimate)")


GROUND_COLOUR_ROWS = 0.5
"""Fraction of the image rows, from the bottom, whose ground-coloured pixels the ground plane is
fitted to: a camera looking ahead sees the ground below the middle row, and grey buildings or
sky above it can take the colour of grey ground."""

LOWER_PART_FOR_GROUND = 1.0 / 3.0
"""Fraction of the image rows, from the bottom, searched for the ground when colour fails."""


def _bottom_rows(shape: tuple[int, int], fraction: float) -> np.ndarray:
    """``bool`` mask of the bottom ``fraction`` of the rows of an image of ``shape``."""
    mask = np.zeros(shape, dtype=bool)
    mask[int(round(shape[0] * (1.0 - fraction))):] = True
    return mask


RECTIFICATION_CHECK_SIDE_PX = 640
"""The rectification check matches features on images shrunk to at most this side (speed)."""

RECTIFICATION_CHECK_FEATURES = 1000
"""Keypoints per image of the rectification check (the descriptor matching grows with their square)."""

RECTIFICATION_CHECK_ORB_LEVELS = 3
"""ORB pyramid levels of the rectification check: a stereo pair shows the scene at one scale."""

MIN_GROUND_COLOURED_FRACTION = 0.05
"""Matched ground-coloured pixels (fraction of the image) that must lie on a ground-like plane
for the colour labels to be trusted."""


MAX_GROUND_TILT_DEG = 45.0
"""A fitted plane whose normal is farther than this from the camera's vertical is not the ground."""


def _fit_ground(disparity: np.ndarray, mask: np.ndarray, calibration: StereoCalibration | None) -> GroundPlane:
    """Fit the ground plane within ``mask``; refuse a plane standing upright: with a calibration,
    one tilted more than :data:`MAX_GROUND_TILT_DEG` from the camera's vertical; without, one
    whose disparity changes faster across the image than down it (the ground seen by a camera
    rolled more than 45 degrees, or a wall turned away: Middlebury Cones' back wall, b = 0.010
    and a = -0.017 px of disparity per pixel, was taken for the ground and the cones in front
    of it rejected as lying under it)."""
    plane = fit_ground_plane(disparity, mask=mask)
    if calibration is not None:
        tilt = tilt_from_camera_vertical_deg(plane, calibration)
        if tilt > MAX_GROUND_TILT_DEG:
            raise InvalidInputError(f"the best plane is tilted {tilt:.0f} degrees from the camera's vertical: "
                                    f"a wall or a large object, not the ground")
    elif abs(plane.a) >= plane.b:
        raise InvalidInputError(f"the best plane's disparity changes faster across the image than down it, "
                                f"{plane.a:+.3f} against {plane.b:+.3f} px per pixel: a wall or a large object, "
                                f"not the ground")
    return plane


def _ground_plane(disparity: np.ndarray, ground_mask: np.ndarray,
                  calibration: StereoCalibration | None) -> tuple[GroundPlane | None, bool]:
    """The ground plane, and whether the phase-1 colour labels can be trusted.

    The colour labels are not trusted when many ground-coloured pixels have a disparity but
    no ground-like plane fits them: the reference area then shows a wall or a large object.
    """
    try:
        return _fit_ground(disparity, ground_mask & _bottom_rows(disparity.shape, GROUND_COLOUR_ROWS), calibration), True
    except InvalidInputError as exc:
        colour_failure = str(exc)
    matched_ground = np.count_nonzero(ground_mask & np.isfinite(disparity))
    colour_trusted = matched_ground < MIN_GROUND_COLOURED_FRACTION * disparity.size
    if not colour_trusted:
        logger.warning("the pixels coloured like the reference area do not lie on a ground plane (%s): an "
                       "obstacle may cover the reference area; obstacles are found from geometry alone",
                       colour_failure)
    try:
        return _fit_ground(disparity, _bottom_rows(disparity.shape, LOWER_PART_FOR_GROUND), calibration), colour_trusted
    except InvalidInputError as exc:
        logger.warning("no ground plane (%s); flat markings cannot be told from obstacles", exc)
        return None, colour_trusted


def _obstacle_candidates(segmentation: SegmentationResult, disparity: np.ndarray, ground: GroundPlane | None,
                         calibration: StereoCalibration | None, config: DetectionConfig,
                         min_excess_px: float | np.ndarray, colour_trusted: bool) -> np.ndarray:
    """Phase-1 obstacle pixels, plus ground-coloured pixels standing clearly above the plane
    (or every matched pixel when the colour labels are not trusted); with a calibration, only
    those within ``config.obstacles.max_distance_m`` (:func:`_within_range`).

    "Clearly": higher than ``config.geometric_min_height_m`` and with a disparity at least
    ``min_excess_px`` (one number, or per pixel) above the plane's, so that the disparity noise of
    far ground (where a small disparity error is a large height) does not raise it.
    """
    if not colour_trusted:
        candidates = np.isfinite(disparity)
    else:
        candidates = segmentation.labels == Label.OBSTACLE.value
        if ground is not None and calibration is not None and config.geometric_min_height_m > 0:
            candidates |= raised_pixels(ground, disparity, segmentation.ground_mask, calibration,
                                        min_height_m=config.geometric_min_height_m, min_excess_px=min_excess_px,
                                        strict=True)
    return _within_range(candidates, disparity, calibration, config.obstacles.max_distance_m)


def _within_range(pixels: np.ndarray, disparity: np.ndarray, calibration: StereoCalibration | None,
                  max_distance_m: float) -> np.ndarray:
    """``pixels`` (``bool (H, W)``) without those deeper than ``max_distance_m`` (metres): their
    disparity (``float32 (H, W)``, pixels, NaN where unmatched) must be at least
    ``f B / max_distance_m - doffs``. Without a calibration, ``pixels`` as they are.

    Obstacles farther than that are not reported (:class:`~stereo_obstacles.obstacles.ObstacleParameters`),
    and their pixels are left out of the obstacle stage rather than grouped, measured and dropped:
    on a road scene most groups lie beyond (``docs/pipeline.md``, session 47).
    """
    if calibration is None:
        return pixels
    return pixels & (disparity >= calibration.focal_baseline_px_m / max_distance_m - calibration.doffs_px)


def _not_clearly_raised(config: DetectionConfig) -> str:
    """Why a group that is high enough above the ground plane still does not stand."""
    floor = f"{config.geometric_min_excess_px:g} px"
    if config.standing_significance is None:
        return f"not clearly above the ground plane: its disparity exceeds the plane's by less than {floor}"
    return (f"not clearly above the ground plane: its disparity exceeds the plane's by less than {floor} or "
            f"{config.standing_significance:g} times its uncertainty (image noise or compression)")


def _min_excess_px(left: np.ndarray, right: np.ndarray, disparity: np.ndarray, config: DetectionConfig,
                   needed: bool) -> float | np.ndarray:
    """How far (pixels) a pixel's disparity must exceed the ground plane's for it to stand:
    ``geometric_min_excess_px``, or per pixel at least ``standing_significance`` times its
    disparity uncertainty (``float32 (H, W)``). Only the calibrated test with a ground plane uses
    it (``needed``); otherwise the number is returned without computing the uncertainty. (The
    matcher converts the pair to grey too but does not return it: 0.8 ms twice at 640x480.)"""
    if config.standing_significance is None or not needed:
        return config.geometric_min_excess_px
    left_grey, right_grey = to_grey(left, "left"), to_grey(right, "right")
    sigma = disparity_sigma_px(left_grey, pair_noise_sigma(left_grey, right_grey, disparity),
                               max_sigma_px=config.standing_max_sigma_px)
    return np.maximum(np.float32(config.geometric_min_excess_px), np.float32(config.standing_significance) * sigma)


FOOT_REACH_PX = 2
"""A flat group within this many pixels of a reported obstacle is that obstacle's foot."""


def _pieces_of_one_object(obstacles: ObstacleList, runs: BracketedRuns | None, measured: np.ndarray,
                          disparity: np.ndarray, colour: ColourCue | None, calibration: StereoCalibration,
                          config: DetectionConfig) -> list[tuple[int, int]]:
    """The pairs of obstacle ids that are pieces of one object: the two outlines of a textureless
    face (from the fill's ``runs``, :mod:`stereo_obstacles.face_joining`) and pieces standing on
    one place of the ground (:mod:`stereo_obstacles.footprint_joining`, on the ``measured``
    disparity the obstacles were measured on)."""
    pairs = []
    if runs is not None and config.face_joining is not None:
        pairs += obstacles_sharing_a_face(runs, obstacles.id_map, disparity, calibration, config.face_joining)
    if colour is not None and config.footprint_joining is not None:
        pairs += pieces_of_one_object(obstacles, measured, colour, calibration, config.footprint_joining)
    return pairs


def _feet(flat_groups: np.ndarray, id_map: np.ndarray) -> set[int]:
    """The numbers of the flat groups (``int (H, W)``, 0: none) touching a reported obstacle
    (``id_map``, ``int (H, W)``, 0: none).

    The bottom few centimetres of an object standing on the ground are as flat as a marking;
    they belong to the object and are not reported as a rejected marking.
    """
    size = 2 * FOOT_REACH_PX + 1
    near = cv2.dilate((id_map > 0).astype(np.uint8), np.ones((size, size), np.uint8)) > 0
    return set(np.unique(flat_groups[near & (flat_groups > 0)]).tolist())


def _flat_groups(disparity: np.ndarray, flat_candidates: np.ndarray, calibration: StereoCalibration | None,
                 ground: GroundPlane, config: DetectionConfig
                 ) -> tuple[np.ndarray, dict[int, Obstacle | RejectedGroup]]:
    """The flat candidates (``bool (H, W)``) grouped, and each group measured
    (:func:`~stereo_obstacles.obstacles.measure_groups`). They are only reported as rejected, so
    they are not split into depth layers."""
    groups = group_obstacle_pixels(disparity, flat_candidates, replace(config.grouping, split_tolerance_px=0.0))
    return groups, measure_groups(groups, disparity, calibration, ground, config.obstacles)


def _depth(disparity: np.ndarray, calibration: StereoCalibration | None) -> np.ndarray | None:
    """The depth map (``float32 (H, W)``, metres), ``None`` without a calibration."""
    return disparity_to_depth(disparity, calibration) if calibration is not None else None


def warm_up() -> float:
    """Compile every kernel of :func:`detect` on a small rendered pair, and the own-colour stage's
    cover, which that pair does not build (:func:`~stereo_obstacles.own_colour_matching.compile_cover`);
    return the seconds spent.

    numba caches the compiled code on disk, so only the first process pays in full. The pair is
    320 x 240, the smallest matched as 640 x 480 pairs are (grown at half size, refined at full
    size); at 160 x 120 (matched at full size) the first 640 x 480 pair still compiled for
    0.6 s. With the kernels cached, a first call in a process takes 1.4 s at either size, most
    of it making the scene's textures (once per process: 0.4 s in ``demo``, which has rendered).
    """
    from stereo_obstacles.synthetic import default_scene, render_pair

    started = time.perf_counter()
    pair = render_pair(default_scene(320, 240))
    detect(pair.left, pair.right, pair.calibration)
    compile_cover()
    return time.perf_counter() - started


def _colour_stage(left: np.ndarray, right: np.ndarray, config: DetectionConfig, calibrated: bool,
                  timings: dict[str, float]
                  ) -> tuple[SegmentationResult, ColourCue | None, np.ndarray | None, RectificationCheck | None]:
    """Phase 1 with the colour cue of the grouping (``None`` when the split along colour is off)
    and, for a calibrated pair, the candidates of the textureless fill (``None`` when it is off),
    then the rectification check; their times written to ``timings`` (seconds)."""
    t = time.perf_counter()
    segmentation = segment(left, reference=config.reference, params=config.segmentation)
    colour = (colour_cue(left, segmentation.labels == Label.OBSTACLE.value, config.grouping.colour_split)
              if config.grouping.colour_split is not None else None)
    textureless = (textureless_candidates(segmentation.labels, left, config.textureless_fill)
                   if calibrated and config.textureless_fill is not None else None)
    timings["segmentation"] = time.perf_counter() - t
    t = time.perf_counter()
    rectification = pair_rectification_check(left, right) if config.check_rectification else None
    timings["rectification_check"] = time.perf_counter() - t
    return segmentation, colour, textureless, rectification


def pair_rectification_check(left: np.ndarray, right: np.ndarray) -> RectificationCheck:
    """The rectification check :func:`detect` makes of a pair (ORB features on copies of at most
    :data:`RECTIFICATION_CHECK_SIDE_PX`; a warning is logged when the pair is not rectified or
    looks swapped), for a caller that checks a stream's first frame before writing anything."""
    return check_rectification(left, right, method="orb", max_side_px=RECTIFICATION_CHECK_SIDE_PX,
                               max_features=RECTIFICATION_CHECK_FEATURES, orb_levels=RECTIFICATION_CHECK_ORB_LEVELS)


def _match_stage(left: np.ndarray, right: np.ndarray, config: DetectionConfig, seed_points, disparity_estimate,
                 timings: dict[str, float]):
    """Phase 2: ``(disparity, matched)`` with the islands matched to a repeat of the texture
    around them and the matches the right camera cannot see removed;
    its time written to ``timings["matching"]`` (seconds)."""
    t = time.perf_counter()
    if disparity_estimate is None:
        if config.matching_scale != DEFAULT_MATCHING_SCALE:   # the default is raised as documented, unsaid
            warn_if_scale_raised(left.shape[0], left.shape[1], config.matching_scale)
        disparity, matched = match_at_scale(left, right, config.matching_scale, seed_points=seed_points,
                                            **pipeline_match_kwargs(config.matching))
    else:
        matched = refine_at_full_size(left, right, disparity_estimate, **pipeline_match_kwargs(config.matching))
        disparity = matched.disparity
    if config.repeated_texture is not None:
        disparity = np.where(repeat_islands(disparity, left, right, config.repeated_texture), np.float32(np.nan),
                             disparity)
    if config.visibility is not None:
        disparity = np.where(hidden_in_right(disparity, config.visibility), np.float32(np.nan), disparity)
    timings["matching"] = time.perf_counter() - t
    return disparity, matched


def detect(left: np.ndarray, right: np.ndarray, calibration: StereoCalibration | None = None, *,
           config: DetectionConfig = DetectionConfig(), seed_points: np.ndarray | None = None,
           disparity_estimate: np.ndarray | None = None) -> DetectionResult:
    """Find the obstacles in a rectified colour stereo pair.

    Parameters
    ----------
    left, right
        ``uint8`` RGB images ``(H, W, 3)`` of the same size, rectified (rows correspond);
        ``uint16`` ones are scaled to 8 bits first (:func:`stereo_obstacles.fileio.to_uint8`).
        ``cv2.imread`` gives BGR: convert with ``cv2.cvtColor(image, cv2.COLOR_BGR2RGB)``, or read
        with :func:`stereo_obstacles.fileio.read_image` (the colours decide what is ground).
    calibration
        The rectified calibration; without it distances stay in pixels and disparities.
    config
        Options of every stage.
    seed_points
        ``(N, 3)`` rows of ``(x, y, d)`` seeding the matcher instead of its edge seeds (for
        example the previous frame's matches, :mod:`stereo_obstacles.temporal_seeds`).
    disparity_estimate
        ``float (H, W)`` full-size disparity (NaN: none) to refine instead of growing seeds: every
        pixel with an estimate is matched again near it on the full-size pair and nothing else is
        matched (:func:`stereo_obstacles.scaled_matching.refine_at_full_size`; for example the
        previous frame's disparity). Not together with ``seed_points``.

    Returns
    -------
    DetectionResult

    Raises
    ------
    InvalidInputError, ImageMismatchError, CalibrationError
        Images that are not RGB or differ in size; a calibration of another image size.

    Examples
    --------
    >>> from stereo_obstacles.synthetic import default_scene, render_pair
    >>> pair = render_pair(default_scene(320, 240))
    >>> result = detect(pair.left, pair.right, pair.calibration)
    >>> [round(o.distance_m, 1) for o in result.obstacles.obstacles]
    [3.1, 4.0, 4.6, 6.5, 6.5, 8.8]
    """
    _check_inputs(left, right, calibration, config)
    _check_hints(seed_points, disparity_estimate, left.shape[:2], config)
    left, right = to_uint8(left, right)
    if calibration is not None:     # checked, and warned of when it states no size and fits other images
        calibration = sized_for_images(calibration, left.shape[1], left.shape[0])
    timings: dict[str, float] = {}
    start = time.perf_counter()
    # phase 1 and the rectification check on a pool thread while the matcher runs here, on the
    # core its serial stages leave idle (whole call 4-7 % faster: docs/pipeline.md, "Speed")
    stage_times: dict[str, float] = {}
    (disparity, matched), (segmentation, colour, textureless, rectification) = run_each_in_threads([
        (_match_stage, left, right, config, seed_points, disparity_estimate, stage_times),
        (_colour_stage, left, right, config, calibration is not None, stage_times)])
    timings.update((name, stage_times[name]) for name in ("segmentation", "rectification_check", "matching"))

    d_max = disparity_range(left.shape[1], 0, config.matching.max_disparity)[1]
    warn_if_range_cut_off(disparity, d_max, None if calibration is None
                          else calibration.focal_baseline_px_m / (d_max + calibration.doffs_px),
                          default_limit=config.matching.max_disparity is None)
    t = time.perf_counter()
    # the disparity uncertainty beside the ground plane: it does not need the plane, only whether
    # there is one (without one it is not used)
    (ground, colour_trusted), min_excess = run_each_in_threads([
        (_ground_plane, disparity, segmentation.ground_mask, calibration),
        (_min_excess_px, left, right, disparity, config, calibration is not None)])
    if ground is None:
        min_excess = config.geometric_min_excess_px
    candidates = _obstacle_candidates(segmentation, disparity, ground, calibration, config, min_excess, colour_trusted)
    standing = standing_pixels(candidates, disparity, ground, calibration, config.obstacles, min_excess_px=min_excess)
    # beside the grouping of the standing pixels: the depth map and the flat groups (measured
    # whole; the feet of the obstacles are left out of their list once the obstacles are known)
    calls = [(partial(group_obstacle_pixels, colour=colour, calibration=calibration), disparity, standing,
              config.grouping),
             (_depth, disparity, calibration)]
    if ground is not None:
        calls.append((_flat_groups, disparity, candidates & ~standing, calibration, ground, config))
    groups, depth, *flat = run_each_in_threads(calls)
    if config.leftover is not None and ground is not None and calibration is not None:
        groups = leftover_groups(groups, disparity, standing, segmentation.labels, ground, calibration,
                                 config.grouping, config.leftover)
    measured = disparity
    hidden_rejected: tuple[RejectedGroup, ...] = ()
    if config.hidden_ground is not None and ground is not None and calibration is not None and colour_trusted:
        groups, hidden_rejected = reject_hidden_ground(groups, disparity, segmentation.labels, ground,
                                                       config.hidden_ground)
    if config.blind_strip is not None:
        extended, measured, _ = extend_into_blind_strip(groups, disparity, segmentation.labels, config.blind_strip,
                                                        chroma=None if colour is None else colour.chroma)
        if extended is not groups:          # a group's plane continued into the strip may run past the range
            added = extended != groups
            groups = np.where(added & ~_within_range(added, measured, calibration, config.obstacles.max_distance_m),
                              groups, extended)
    outcomes = measure_groups(groups, measured, calibration, ground, config.obstacles)
    obstacles = list_obstacles(outcomes, groups, measured, calibration, config.obstacles, with_scan=False)
    if config.fattened_fringes is not None and colour is not None:
        fringes = fattened_fringes(obstacles, colour.chroma, config.fattened_fringes)
        if fringes.any():
            groups, outcomes = measure_without(fringes, groups, outcomes, measured, calibration, ground,
                                               config.obstacles)
            obstacles = list_obstacles(outcomes, groups, measured, calibration, config.obstacles, with_scan=False)
    if config.own_colour is not None and colour is not None:
        taken_out, rematched, new_disparity = own_colour_matches(obstacles, colour.chroma, segmentation.labels,
                                                                 left, right, disparity, config.own_colour)
        if taken_out.any() or rematched.any():
            disparity, measured = (np.where(rematched, new_disparity, d).astype(np.float32)
                                   for d in (disparity, measured))
            depth = _depth(disparity, calibration)
            standing_rematched = standing_pixels(rematched, disparity, ground, calibration, config.obstacles,
                                                 min_excess_px=min_excess)
            # a strip matched beyond the range leaves its obstacle for none
            standing_rematched = _within_range(standing_rematched, disparity, calibration,
                                               config.obstacles.max_distance_m)
            groups, outcomes = measure_without(taken_out | rematched, groups, outcomes, measured, calibration,
                                               ground, config.obstacles)
            pieces = moved_groups(standing_rematched, disparity, int(groups.max(initial=0)) + 1, config.grouping)
            groups = np.where(pieces > 0, pieces, groups)
            outcomes = {**outcomes, **measure_groups(pieces, measured, calibration, ground, config.obstacles)}
            obstacles = list_obstacles(outcomes, groups, measured, calibration, config.obstacles, with_scan=False)
    if calibration is not None:
        filling = textureless is not None and ground is not None and colour_trusted
        runs = (bracketed_runs(textureless, obstacles.id_map, disparity, segmentation.labels, ground,
                               config.textureless_fill) if filling else None)
        pairs = _pieces_of_one_object(obstacles, runs, measured, disparity, colour, calibration, config)
        if pairs:
            groups, obstacles = measure_joined(groups, obstacles, pairs, measured, calibration, ground,
                                               config.obstacles)
            if filling:
                runs = bracketed_runs(textureless, obstacles.id_map, disparity, segmentation.labels, ground,
                                      config.textureless_fill)
        # the scan from the delivered disparity (no blind-strip extrapolation), textureless faces filled
        scan_ids, scan_disparity = obstacles.id_map, disparity
        if filling:
            scan_ids, scan_disparity = paint_runs(obstacles.id_map, disparity, runs)
            obstacles = widen_obstacles(obstacles, scan_ids, scan_disparity, calibration,
                                        config.obstacles.corridor_width_m)
        obstacles = replace(obstacles, scan=obstacle_scan(scan_ids, scan_disparity, calibration, config.obstacles))
    if flat:
        flat_groups, flat_measured = flat[0]
        feet = _feet(flat_groups, obstacles.id_map)
        listed = list_obstacles({group: m for group, m in flat_measured.items() if group not in feet}, flat_groups,
                                disparity, calibration, config.obstacles, with_scan=False)
        # groups high enough but not clearly above the plane in disparity (far, or noisy matches)
        unclear = tuple(RejectedGroup(o.box_px, o.pixel_count, _not_clearly_raised(config)) for o in listed.obstacles)
        obstacles = replace(obstacles, rejected=hidden_rejected + obstacles.rejected + listed.rejected + unclear)
    timings["obstacles"] = time.perf_counter() - t
    timings["total"] = time.perf_counter() - start
    return DetectionResult(segmentation=segmentation, disparity=disparity, match_stats=matched.stats,
                           depth_m=depth, ground=ground, obstacles=obstacles, calibration=calibration,
                           config=config, timings_s=timings, rectification_check=rectification)
