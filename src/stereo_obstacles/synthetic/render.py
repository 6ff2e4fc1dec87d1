"""Render a scene into a stereo pair with exact left-view ground truth.

Each camera casts ``s x s`` rays per pixel (supersampling against jagged edges), shades
them (:mod:`~stereo_obstacles.synthetic.shading`) and averages them in linear light before
the sensor model (:mod:`~stereo_obstacles.synthetic.sensor`). The ground truth comes from
one extra ray through each left pixel centre: its depth ``Z``, the disparity
``d = f B / Z`` it would have in the rectified pair, its class, the obstacle it belongs
to, whether the sun reaches it, and whether the rectified right camera sees the same point
(the line from the point to the right optical centre is clear and ``u - d`` is inside the
right image).
"""

from __future__ import annotations

import logging
import math
import numbers
from dataclasses import dataclass, field

import numpy as np

from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import plain_numbers
from stereo_obstacles.labels import Label
from stereo_obstacles.synthetic.raycast import (GROUND, SKY, Hits, blocked_towards_direction,
                                                blocked_towards_point, trace)
from stereo_obstacles.synthetic.rig import CameraPose, RightCameraError, camera_poses
from stereo_obstacles.synthetic.scene import Scene
from stereo_obstacles.synthetic.sensor import compress_jpeg, develop
from stereo_obstacles.synthetic.shading import shade, surface_albedo
from stereo_obstacles.synthetic.truth import ObstacleTruth, obstacle_truths

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class RenderOptions:
    """How to image a scene.

    Attributes
    ----------
    supersample : int
        Rays per pixel along each axis (1..4); 2 means 4 rays per pixel and about 4 times
        the time. Textures are filtered anyway; supersampling smooths obstacle outlines.
    blur_sigma_px : float
        Lens blur (Gaussian standard deviation) in pixels, 0..3.
    shadows : bool
        Cast shadows (``False``: every surface facing the sun is sunlit).
    noise_sigma : float
        Gaussian sensor noise in grey levels (0..50).
    right_gain : float
        Gain of the right camera relative to the left (linear light, 0.25..4).
    right_bias : float
        Brightness offset of the right image, grey levels (-100..100).
    exposure : float
        Linear exposure of both cameras (radiance 1/exposure saturates).
    right_error : RightCameraError
        Known rotation / vertical offset of the right camera (zero: rectified).
    jpeg_quality : int or None
        Deliver both images JPEG-compressed at this quality (1..100), as a webcam in MJPG
        mode does; ``None``: uncompressed.
    """

    supersample: int = 1
    blur_sigma_px: float = 0.5
    shadows: bool = True
    noise_sigma: float = 0.0
    right_gain: float = 1.0
    right_bias: float = 0.0
    exposure: float = 2.0
    right_error: RightCameraError = field(default_factory=RightCameraError)
    jpeg_quality: int | None = None

    def __post_init__(self) -> None:
        plain_numbers(self)                      # NumPy scalars as Python numbers (JSON-ready)
        if not isinstance(self.supersample, int) or isinstance(self.supersample, bool) \
                or not 1 <= self.supersample <= 4:
            raise InvalidInputError(f"supersample must be an integer in [1, 4], got {self.supersample!r}")
        ranges = {"blur_sigma_px": (0.0, 3.0), "noise_sigma": (0.0, 50.0), "right_gain": (0.25, 4.0), "right_bias": (-100.0, 100.0),
                  "exposure": (0.01, 100.0)}
        for name, (lo, hi) in ranges.items():
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and lo <= value <= hi):
                raise InvalidInputError(f"{name} must be in [{lo}, {hi}], got {value!r}")
        if not isinstance(self.right_error, RightCameraError):
            raise InvalidInputError("right_error must be a RightCameraError")
        quality = self.jpeg_quality
        if quality is not None and (not isinstance(quality, numbers.Integral) or isinstance(quality, bool)
                                    or not 1 <= quality <= 100):
            raise InvalidInputError(f"jpeg_quality must be None or an integer in [1, 100], got {quality!r}")


@dataclass(frozen=True, eq=False)
class SyntheticPair:
    """A rendered stereo pair and its exact ground truth (all maps are for the left view).

    Attributes
    ----------
    left, right : numpy.ndarray
        RGB ``uint8 (H, W, 3)`` images.
    disparity : numpy.ndarray
        ``float32 (H, W)`` pixels, ``f B / Z`` in the rectified pair; NaN for sky.
    depth : numpy.ndarray
        ``float32 (H, W)`` camera depth ``Z`` in metres; NaN for sky.
    labels : numpy.ndarray
        ``uint8 (H, W)`` :class:`~stereo_obstacles.labels.Label` values: GROUND, SHADOW (ground
        in cast shadow), OBSTACLE, MARKING (painted ground, lit or shadowed), SKY.
    instances : numpy.ndarray
        ``uint8 (H, W)``: the ``obstacle_id`` seen at each pixel, 0 for ground and sky.
    cast_shadow : numpy.ndarray
        ``bool (H, W)``: the surface faces the sun but another object blocks it (any class).
    nonocc : numpy.ndarray
        ``bool (H, W)``: the point is also visible in the rectified right view.
    calibration : StereoCalibration
        The rectified calibration of the pair.
    right_rotation : numpy.ndarray
        ``(3, 3)`` OpenCV ``R``: a left-camera point ``X`` is ``R @ X + T`` in the true right camera.
    right_translation_m : numpy.ndarray
        ``(3,)`` OpenCV ``T`` in metres.
    right_intrinsics : numpy.ndarray
        ``(3, 3)`` true camera matrix of the right camera (vertical offset included).
    obstacles : tuple of ObstacleTruth
        Every obstacle, nearest first.
    scene : Scene
        What was rendered.
    options : RenderOptions
        How it was rendered.
    forward_m : float
        How far the rig had moved forward (sequences), metres.
    """

    left: np.ndarray
    right: np.ndarray
    disparity: np.ndarray
    depth: np.ndarray
    labels: np.ndarray
    instances: np.ndarray
    cast_shadow: np.ndarray
    nonocc: np.ndarray
    calibration: StereoCalibration
    right_rotation: np.ndarray
    right_translation_m: np.ndarray
    right_intrinsics: np.ndarray
    obstacles: tuple[ObstacleTruth, ...]
    scene: Scene
    options: RenderOptions
    forward_m: float = 0.0


@dataclass(frozen=True, eq=False)
class _View:
    """A traced grid of rays with its sunlight and paint per sample."""

    hits: Hits
    surface: np.ndarray
    sun_blocked: np.ndarray
    paint: np.ndarray


def _trace_view(scene: Scene, pose: CameraPose, supersample: int, shadows: bool) -> _View:
    prims = scene.primitives()
    hits = trace(pose, [(p, oid) for p, oid, _ in prims], supersample)
    surface = np.flatnonzero(hits.owner.ravel() != SKY)
    points = tuple(c.ravel()[surface] for c in hits.point)
    normals = tuple(c.ravel()[surface] for c in hits.normal)
    if shadows:
        blocked = blocked_towards_direction(points, normals, scene.lighting.sun_direction(),
                                            [p for p, _, _ in prims])
    else:
        blocked = np.zeros(surface.size, dtype=bool)
    paint = np.full(hits.depth.shape, -1, dtype=np.int16)
    on_ground = hits.owner == GROUND
    for index, marking in enumerate(scene.markings):
        painted = on_ground & marking.contains(hits.point[0], hits.point[1])
        paint[painted] = index
    return _View(hits, surface, blocked, paint)


def _image_radiance(scene: Scene, view: _View, supersample: int) -> np.ndarray:
    """Linear radiance ``(H, W, 3)``: the average of each pixel's samples."""
    hits = view.hits
    albedo = surface_albedo(hits, view.surface, scene.primitives(), scene.ground, view.paint,
                            [m.material for m in scene.markings], scene.rig.focal_px, supersample)
    radiance = shade(hits, albedo, view.surface, ~view.sun_blocked, scene.lighting)
    hs, ws = hits.depth.shape
    s = supersample
    return radiance.reshape(hs // s, s, ws // s, s, 3).mean(axis=(1, 3))


def _labels(view: _View) -> tuple[np.ndarray, np.ndarray]:
    """Label image and the cast-shadow mask from a one-ray-per-pixel view."""
    hits = view.hits
    shape = hits.depth.shape
    sun = np.zeros(shape, dtype=bool).ravel()
    sun[view.surface] = view.sun_blocked
    cast_shadow = sun.reshape(shape)
    labels = np.full(shape, int(Label.SKY), dtype=np.uint8)
    labels[hits.owner > 0] = Label.OBSTACLE
    ground = hits.owner == GROUND
    labels[ground] = np.where(cast_shadow[ground], Label.SHADOW.value, Label.GROUND.value)
    labels[view.paint >= 0] = Label.MARKING
    return labels, cast_shadow


def _faces_sun(hits: Hits, sun: np.ndarray) -> np.ndarray:
    nx, ny, nz = hits.normal
    return nx * sun[0] + ny * sun[1] + nz * sun[2] > 0


def render_pair(scene: Scene, options: RenderOptions | None = None, *, forward_m: float = 0.0,
                frame: int = 0) -> SyntheticPair:
    """Render ``scene`` into a stereo pair with exact ground truth.

    Parameters
    ----------
    scene : Scene
        What to render (see :func:`~stereo_obstacles.synthetic.default_scene`).
    options : RenderOptions, optional
        Supersampling, shadows, sensor noise and camera differences.
    forward_m : float
        Move the rig this far forward (world ``+y``), metres.
    frame : int
        Frame number: seeds the sensor noise together with ``scene.seed``.

    Returns
    -------
    SyntheticPair

    Examples
    --------
    >>> from stereo_obstacles.synthetic import default_scene, render_pair
    >>> pair = render_pair(default_scene(width_px=160, height_px=120))
    >>> pair.left.shape, pair.disparity.dtype
    ((120, 160, 3), dtype('float32'))
    """
    options = RenderOptions() if options is None else options
    if not (isinstance(forward_m, (int, float)) and math.isfinite(forward_m)):
        raise InvalidInputError(f"forward_m must be a finite number of metres, got {forward_m!r}")
    if not isinstance(frame, int) or frame < 0:
        raise InvalidInputError(f"frame must be an integer >= 0, got {frame!r}")
    rig = scene.rig
    s = options.supersample
    left_pose, right_pose, rectified_right = camera_poses(rig, options.right_error, forward_m)

    left_view = _trace_view(scene, left_pose, s, options.shadows)
    right_view = _trace_view(scene, right_pose, s, options.shadows)
    truth_view = left_view if s == 1 else _trace_view(scene, left_pose, 1, options.shadows)

    rng = np.random.default_rng([scene.seed, frame])
    left = develop(_image_radiance(scene, left_view, s), blur_sigma_px=options.blur_sigma_px,
                   exposure=options.exposure, gain=1.0,
                   bias_levels=0.0, noise_sigma=options.noise_sigma, rng=rng)
    right = develop(_image_radiance(scene, right_view, s), blur_sigma_px=options.blur_sigma_px,
                    exposure=options.exposure, gain=options.right_gain, bias_levels=options.right_bias,
                    noise_sigma=options.noise_sigma, rng=rng)
    if options.jpeg_quality is not None:
        left, right = compress_jpeg(left, options.jpeg_quality), compress_jpeg(right, options.jpeg_quality)

    hits = truth_view.hits
    solid = hits.owner != SKY
    depth = np.where(solid, hits.depth, np.nan).astype(np.float32)
    calibration = rig.calibration()
    with np.errstate(divide="ignore", invalid="ignore"):
        disparity = (calibration.focal_baseline_px_m / depth.astype(np.float64)).astype(np.float32)
    labels, cast_shadow = _labels(truth_view)
    cast_shadow &= _faces_sun(hits, scene.lighting.sun_direction())
    instances = np.where(hits.owner > 0, hits.owner, 0).astype(np.uint8)

    surface = truth_view.surface
    blocked = blocked_towards_point(tuple(c.ravel()[surface] for c in hits.point),
                                    tuple(c.ravel()[surface] for c in hits.normal),
                                    rectified_right, [p for p, _, _ in scene.primitives()])
    u_right = np.arange(rig.width_px)[None, :] - disparity
    nonocc = np.zeros(depth.size, dtype=bool)
    nonocc[surface] = ~blocked
    nonocc = nonocc.reshape(depth.shape) & (u_right >= 0) & (u_right <= rig.width_px - 1)

    r, t = options.right_error.extrinsics(rig)
    pair = SyntheticPair(
        left=left, right=right, disparity=disparity, depth=depth, labels=labels, instances=instances,
        cast_shadow=cast_shadow, nonocc=nonocc, calibration=calibration, right_rotation=r,
        right_translation_m=t, right_intrinsics=options.right_error.right_intrinsic_matrix(rig),
        obstacles=obstacle_truths(scene.obstacles, left_pose, depth, instances),
        scene=scene, options=options, forward_m=float(forward_m))
    logger.debug("rendered %dx%d pair (seed %d, forward %.2f m)", rig.width_px, rig.height_px,
                 scene.seed, forward_m)
    return pair
