"""The files of a synthetic scene folder (what ``stereo-obstacles scene --out DIR`` writes).

========================  ==============================================================
``left.png``/``right.png``  RGB 8-bit images (the right one unrectified when a right
                          camera error was asked for)
``disparity.pfm``         left-view disparity ``f B / Z`` in pixels, float, ``+inf`` = sky
``depth.npy``             left-view depth ``Z`` in metres, float32, NaN = sky
``labels.png``            :class:`~stereo_obstacles.labels.Label` per pixel (uint8);
                          a painted marking is MARKING whether lit or in shadow
``labels_preview.png``    the labels in colour, for people
``instances.png``         ``obstacle_id`` per pixel (uint8), 0 = ground or sky
``shadow.png``            255 where a surface faces the sun but lies in a cast shadow
``nonocc.png``            255 where the left pixel is also visible in the rectified right view
``obstacles.json``        every obstacle: position, size, distances, visible pixels
``calibration.json``      the rectified calibration (:mod:`stereo_obstacles.calibration`): the
                          nominal rig's, which the right image follows only without a
                          right camera error
``camera_pair.json``      only with a right camera error: the true calibration of the pair
                          before rectification (:mod:`stereo_obstacles.camera_calibration`),
                          for ``stereo-obstacles rectify --calib``
``scene.json``            seed, generation parameters, render options, the right camera's
                          true pose, package version
========================  ==============================================================

The set is staged in a hidden folder and moved in only when every file is written.
"""

from __future__ import annotations

import json
import os
from dataclasses import asdict
from pathlib import Path

import numpy as np

from stereo_obstacles import __version__
from stereo_obstacles.atomic import refuse_foreign_files, staged_directory, write_text_atomic
from stereo_obstacles.calibration import write_calibration_json
from stereo_obstacles.camera_calibration import CameraPairCalibration, write_camera_pair_json
from stereo_obstacles.errors import OutputError
from stereo_obstacles.fileio import write_depth, write_disparity, write_image, write_labels
from stereo_obstacles.json_documents import is_document_of
from stereo_obstacles.labels import Label, colorize_labels
from stereo_obstacles.synthetic.render import RenderOptions, SyntheticPair

OBSTACLES_FORMAT = "stereo-obstacles/synthetic-obstacles"
SCENE_FORMAT = "stereo-obstacles/synthetic-scene"
FORMAT_VERSION = 1

SCENE_FILES = ("left.png", "right.png", "disparity.pfm", "depth.npy", "labels.png", "labels_preview.png",
               "instances.png", "shadow.png", "nonocc.png", "obstacles.json", "calibration.json", "camera_pair.json",
               "scene.json")
"""Every file :func:`write_scene_folder` may write (``camera_pair.json`` only for a pair with a right
camera error)."""


def _rounded(value: object) -> object:
    """Floats to 6 decimals (micrometres, micro-pixels), recursively."""
    if isinstance(value, float):
        return round(value, 6)
    if isinstance(value, dict):
        return {k: _rounded(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_rounded(v) for v in value]
    return value


def _json(data: dict) -> str:
    return json.dumps(_rounded(data), indent=2, allow_nan=False) + "\n"


def obstacles_document(pair: SyntheticPair) -> dict:
    """The content of ``obstacles.json``."""
    return {
        "format": OBSTACLES_FORMAT,
        "version": FORMAT_VERSION,
        "units": "metres, pixels",
        "frames": {
            "world": "x right, y forward, z up; ground z = 0; origin on the ground below the left "
                     "camera at forward_m = 0",
            "camera": "left camera, OpenCV: X right, Y down, Z forward (depth)",
        },
        "distances": {
            "distance_m": "horizontal distance on the ground from the point below the left camera to "
                          "the nearest point of the obstacle's footprint",
            "forward_distance_m": "the same along the forward direction (world y) only",
            "nearest_depth_m": "smallest depth Z among the obstacle's visible left pixels (null if none)",
        },
        "forward_m": pair.forward_m,
        "obstacles": [asdict(o) for o in pair.obstacles],
    }


def scene_document(pair: SyntheticPair) -> dict:
    """The content of ``scene.json``."""
    options = pair.options
    return {
        "format": SCENE_FORMAT,
        "version": FORMAT_VERSION,
        "package_version": __version__,
        "seed": pair.scene.seed,
        "forward_m": pair.forward_m,
        "render_options": asdict(options),
        "right_camera": {
            "convention": "X_right = R @ X_left + T (OpenCV stereoCalibrate), metres",
            "R": pair.right_rotation.tolist(),
            "T": pair.right_translation_m.tolist(),
            "K_left": pair.scene.rig.intrinsic_matrix().tolist(),
            "K_right": pair.right_intrinsics.tolist(),
            "rotation_deg_xyz": list(options.right_error.rotation_deg),
            "vertical_offset_px": options.right_error.vertical_offset_px,
            "rectified": options.right_error.is_zero,
        },
        "labels": {label.name: int(label) for label in Label},
        "label_notes": "SHADOW is ground in cast shadow; a painted marking is MARKING lit or shadowed; "
                       "shadow.png marks cast shadow on any surface",
        "scene": pair.scene.to_dict(),
        "files": scene_file_names(pair.options),
    }


def holds_a_scene(folder: str | os.PathLike[str]) -> bool:
    """Whether ``folder`` holds a scene this tool wrote: a ``scene.json`` of its format."""
    return is_document_of(Path(folder) / "scene.json", SCENE_FORMAT)


def refuse_scene_files(*paths: str | os.PathLike[str] | None) -> None:
    """Raise :class:`~stereo_obstacles.errors.OutputError` when one of the output ``paths`` (``None``
    skipped) would replace a file of a rendered scene (:data:`SCENE_FILES` in a folder that
    :func:`holds_a_scene`): its ground truth, its images or its calibration."""
    for path in (Path(p) for p in paths if p is not None):
        if path.name in SCENE_FILES and holds_a_scene(path.parent):
            raise OutputError(f"{path} is a file of the rendered scene in {path.parent} (its images, ground truth "
                              f"or calibration); write it elsewhere")


def check_scene_folder(folder: str | os.PathLike[str]) -> None:
    """Raise :class:`~stereo_obstacles.errors.OutputError` when a scene written into ``folder``
    would replace files that are not an earlier scene's: without a ``scene.json`` of this tool
    there, any file of the names a scene writes (:data:`SCENE_FILES`: a detection report's
    ``obstacles.json`` and ``labels.png``, a user's own ``left.png``)."""
    refuse_foreign_files(folder, SCENE_FILES, ours=holds_a_scene(folder), what="scene",
                         missing="no scene.json of it")


def write_scene_folder(out_dir: str | os.PathLike[str], pair: SyntheticPair) -> list[Path]:
    """Write all :data:`SCENE_FILES` of ``pair`` into ``out_dir`` as one set.

    Raises
    ------
    OutputError
        The folder cannot be created or written, or holds files of those names that are not an
        earlier scene's (:func:`check_scene_folder`); nothing is left half-written.
    """
    check_scene_folder(out_dir)
    names = scene_file_names(pair.options)
    unrectified = "camera_pair.json" in names
    with staged_directory(out_dir, last=("obstacles.json", "scene.json"),
                          stale=tuple(name for name in SCENE_FILES if name not in names), kind="scene") as stage:
        write_image(stage / "left.png", pair.left)
        write_image(stage / "right.png", pair.right)
        write_disparity(stage / "disparity.pfm", pair.disparity)
        write_depth(stage / "depth.npy", pair.depth)
        write_labels(stage / "labels.png", pair.labels)
        write_image(stage / "labels_preview.png", colorize_labels(pair.labels))
        write_labels(stage / "instances.png", pair.instances)
        write_labels(stage / "shadow.png", pair.cast_shadow.astype(np.uint8) * 255)
        write_labels(stage / "nonocc.png", pair.nonocc.astype(np.uint8) * 255)
        write_text_atomic(stage / "obstacles.json", _json(obstacles_document(pair)))
        write_calibration_json(stage / "calibration.json", pair.calibration)
        if unrectified:
            write_camera_pair_json(stage / "camera_pair.json", true_camera_pair(pair))
        write_text_atomic(stage / "scene.json", _json(scene_document(pair)))
    return [Path(out_dir) / name for name in names]


def scene_file_names(options: RenderOptions) -> list[str]:
    """The :data:`SCENE_FILES` written for a pair rendered with ``options``: ``camera_pair.json``
    only when the right camera is off the rectified pose."""
    return [name for name in SCENE_FILES if name != "camera_pair.json" or not options.right_error.is_zero]


def true_camera_pair(pair: SyntheticPair) -> CameraPairCalibration:
    """The calibration of ``pair``'s two cameras as rendered, before any rectification: the left
    camera the rectified rig's, the right one with its true matrix, rotation and translation,
    both without lens distortion."""
    height, width = pair.left.shape[:2]
    return CameraPairCalibration(camera_matrix_left=pair.scene.rig.intrinsic_matrix(), distortion_left=np.zeros(5),
                                 camera_matrix_right=np.asarray(pair.right_intrinsics, dtype=np.float64),
                                 distortion_right=np.zeros(5), rotation=np.asarray(pair.right_rotation, np.float64),
                                 translation_m=np.asarray(pair.right_translation_m, np.float64),
                                 width_px=width, height_px=height)
