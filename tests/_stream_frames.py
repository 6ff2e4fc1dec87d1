"""A short synthetic walk (the rig moving forward) rendered once per test session, and writers for it.

Four 160 x 120 frames of the default scene, 0.1 m apart (1 m/s at 10 frames per second), with
their exact ground truth; helpers write them as PNG sequences, two videos or one side-by-side
video with OpenCV.
"""

from __future__ import annotations

import functools
from pathlib import Path

import cv2
import numpy as np

from stereo_obstacles.calibration import write_calibration_json
from stereo_obstacles.synthetic import SyntheticPair, default_scene, render_sequence

SIZE = (160, 120)
N_FRAMES = 4
SPEED_M_PER_FRAME = 0.1
FPS = 10.0


@functools.lru_cache(maxsize=1)
def frames() -> tuple[SyntheticPair, ...]:
    """The rendered walk (cached for the session)."""
    return tuple(render_sequence(default_scene(*SIZE), N_FRAMES, SPEED_M_PER_FRAME))


def _bgr(rgb: np.ndarray) -> np.ndarray:
    return cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR)


def write_sequences(folder: Path, *, repeat: int = 1, left_name: str = "{:04d}.png",
                    right_name: str = "{:04d}.png") -> tuple[Path, Path]:
    """PNG files in ``folder/left`` and ``folder/right`` (the walk repeated ``repeat`` times)."""
    left_dir, right_dir = folder / "left", folder / "right"
    left_dir.mkdir(parents=True)
    right_dir.mkdir(parents=True)
    for i in range(N_FRAMES * repeat):
        pair = frames()[i % N_FRAMES]
        cv2.imwrite(str(left_dir / left_name.format(i)), _bgr(pair.left))
        cv2.imwrite(str(right_dir / right_name.format(i)), _bgr(pair.right))
    return left_dir, right_dir


def write_videos(folder: Path, *, right_frames: int = N_FRAMES) -> tuple[Path, Path]:
    """``left.avi`` and ``right.avi`` (MJPG, near-lossless enough to match)."""
    folder.mkdir(parents=True, exist_ok=True)
    paths = folder / "left.avi", folder / "right.avi"
    fourcc = cv2.VideoWriter_fourcc(*"MJPG")
    for path, side, count in ((paths[0], "left", N_FRAMES), (paths[1], "right", right_frames)):
        writer = cv2.VideoWriter(str(path), fourcc, FPS, SIZE)
        for i in range(count):
            writer.write(_bgr(getattr(frames()[i % N_FRAMES], side)))
        writer.release()
    return paths


def write_side_by_side(path: Path) -> Path:
    """One video whose frames are left and right side by side."""
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), FPS, (2 * SIZE[0], SIZE[1]))
    for pair in frames():
        writer.write(_bgr(np.hstack([pair.left, pair.right])))
    writer.release()
    return path


def write_calibration(path: Path) -> Path:
    """The walk's calibration as this tool's JSON."""
    write_calibration_json(path, frames()[0].calibration)
    return path
