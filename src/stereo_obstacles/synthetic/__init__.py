"""A synthetic stereo world with exact ground truth: the project's built-in default scene.

A rectified pinhole stereo rig (:class:`StereoRig`) stands 0.8-1.6 m above a textured
ground plane (pavement, asphalt, grass or tiles) with obstacles (boxes, poles, cylinders,
wall segments) and flat painted markings, lit by a sun that casts shadows -- including the
shadow of an off-screen tree -- and a bluish sky. Images are ray cast with NumPy; every
texture is defined in world coordinates, so both cameras see the same surface and the
ground truth is exact.

Frames. World: metres, ``x`` right, ``y`` forward, ``z`` up, ground ``z = 0``, origin on the
ground below the left camera. Camera (OpenCV): ``X`` right, ``Y`` down, ``Z`` forward; depth
is the camera ``Z``. Disparity is ``d = f B / Z`` for the rectified pair: left pixel
``(u, v)`` matches right pixel ``(u - d, v)``.

Python API
----------
``default_scene(width_px=640, height_px=480, *, ground="pavement") -> Scene``
    The built-in demo scene (seed 0).
``random_scene(seed, *, width_px, height_px, ground, sun_azimuth_deg, sun_elevation_deg,
n_obstacles, camera_height_m, pitch_deg, markings) -> Scene``
    A random layout per seed for evaluations.
``render_pair(scene, options=RenderOptions(), *, forward_m=0.0, frame=0) -> SyntheticPair``
    Left/right RGB images, disparity, depth, labels, instances, cast shadows, the
    non-occlusion mask, the calibration, the right camera's true pose and the obstacle list.
``render_sequence(scene, n_frames, speed_m_per_frame, options=None) -> Iterator[SyntheticPair]``
    The rig walking forward.
``write_scene_folder(out_dir, pair) -> list[Path]``
    All the files of ``stereo-obstacles scene``, written atomically as one set.
``RenderOptions(supersample, blur_sigma_px, shadows, noise_sigma, right_gain, right_bias,
exposure, right_error=RightCameraError(rotation_deg, vertical_offset_px), jpeg_quality)``
    Imaging options.

Examples
--------
>>> from stereo_obstacles.synthetic import default_scene, render_pair
>>> pair = render_pair(default_scene(160, 120))
>>> pair.left.shape, pair.labels.dtype, len(pair.obstacles) > 0
((120, 160, 3), dtype('uint8'), True)
"""

from stereo_obstacles.synthetic.layout import default_rig, default_scene, random_scene
from stereo_obstacles.synthetic.materials import GROUND_MATERIALS, MATERIALS, Material
from stereo_obstacles.synthetic.primitives import Box, Cylinder, Sphere
from stereo_obstacles.synthetic.render import RenderOptions, SyntheticPair, render_pair
from stereo_obstacles.synthetic.rig import RightCameraError, StereoRig
from stereo_obstacles.synthetic.scene import Lighting, Marking, Obstacle, Scene
from stereo_obstacles.synthetic.scene_files import write_scene_folder
from stereo_obstacles.synthetic.sequence import render_sequence
from stereo_obstacles.synthetic.truth import ObstacleTruth

__all__ = [
    "GROUND_MATERIALS", "MATERIALS", "Box", "Cylinder", "Lighting", "Marking", "Material", "Obstacle",
    "ObstacleTruth", "RenderOptions", "RightCameraError", "Scene", "Sphere", "StereoRig", "SyntheticPair",
    "default_rig", "default_scene", "random_scene", "render_pair", "render_sequence", "write_scene_folder",
]
