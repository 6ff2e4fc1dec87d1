"""Stereo frame sources: two video files, two image sequences, a side-by-side video, two cameras.

Every source yields :class:`StereoFrame` objects (index, timestamp, left and right RGB
``uint8 (H, W, 3)`` images) and closes its files or devices when the iteration ends or
:meth:`StereoSource.close` is called (sources are context managers).

* :class:`VideoPairSource` — two video files, frame *k* of one with frame *k* of the other;
  the timestamp is the left video's position. Files whose frame counts (as the containers
  state them) differ are refused; otherwise the shorter one ends the stream.
* :class:`ImageSequenceSource` — two folders or glob patterns of images (a pattern may cover
  one folder per frame), in natural order of their paths. When both sides hold the same names
  they are paired by name; when they share at least half their names but not all they are
  refused (a frame missing on one side); otherwise by order, and then the counts must agree (a warning when
  the paired names' frame numbers fall out of step). Timestamps are ``index / fps``.
* :class:`SideBySideSource` — one video whose frames hold the left view in the left half and
  the right view in the right half (common cheap stereo cameras); the width must be even.
* :class:`CameraPairSource` — two live cameras by device index; both are *grabbed* before
  either is decoded, to keep the pair as close in time as the drivers allow. Timestamps are
  seconds since the stream opened.

:func:`open_source` picks the kind from the command-line arguments.
"""

from __future__ import annotations

import glob
import logging
import os
import re
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from stereo_obstacles.errors import ImageMismatchError, InputFileError, InvalidInputError
from stereo_obstacles.field_checks import is_finite_real
from stereo_obstacles.image_pairs import check_pair_of_files, refuse_one_file_twice
from stereo_obstacles.fileio import read_image

__all__ = ["SOURCE_KINDS", "CameraPairSource", "ImageSequenceSource", "SideBySideSource", "StereoFrame",
           "StereoSource", "VideoPairSource", "open_source"]

logger = logging.getLogger(__name__)

SOURCE_KINDS = ("auto", "videos", "images", "side-by-side", "cameras")
"""Source kinds :func:`open_source` accepts (``auto`` guesses from the arguments)."""

IMAGE_EXTENSIONS = (".png", ".jpg", ".jpeg", ".ppm", ".pgm", ".bmp", ".tif", ".tiff")
"""File name endings an image sequence folder is filtered by."""


@dataclass(frozen=True, eq=False)
class StereoFrame:
    """One stereo frame of a stream.

    Attributes
    ----------
    index : int
        0, 1, 2, ... in stream order.
    timestamp_s : float
        Seconds since the start of the stream (video position, ``index / fps``, or wall time
        for cameras).
    left, right : ndarray of uint8, shape (H, W, 3)
        RGB images of the same size.
    name : str
        A short name for per-frame outputs (for image sequences the left file's path below the
        folder common to all, without its ending: its stem, or ``frame_0003_left``; else
        ``frame_000123``).
    """

    index: int
    timestamp_s: float
    left: np.ndarray
    right: np.ndarray
    name: str

    def __post_init__(self) -> None:
        for side in ("left", "right"):
            image = getattr(self, side)
            if not isinstance(image, np.ndarray) or image.ndim != 3 or image.shape[2] != 3:
                raise InvalidInputError(f"frame {self.index}: {side} must be an RGB (H, W, 3) array, got "
                                        f"{getattr(image, 'shape', type(image).__name__)}")
        if self.left.shape != self.right.shape:
            raise ImageMismatchError(f"frame {self.index}: left is {self.left.shape[1]}x{self.left.shape[0]} "
                                     f"but right is {self.right.shape[1]}x{self.right.shape[0]}")
        if not is_finite_real(self.timestamp_s):
            raise InvalidInputError(f"frame {self.index}: timestamp_s must be a finite number, got {self.timestamp_s!r}")


class StereoSource:
    """Base of the sources: iterate for frames; ``with`` or :meth:`close` releases them.

    Attributes
    ----------
    total_frames : int or None
        Number of frames when known in advance (files), ``None`` for cameras.
    is_live : bool
        True for cameras (no end; report frames per second rather than progress).
    description : str
        What is being read, for messages.
    fps : float
        Nominal frame rate, frames per second (what an output video is written at).
    """

    total_frames: int | None = None
    fps: float = 30.0
    is_live: bool = False
    description: str = ""

    def __iter__(self) -> Iterator[StereoFrame]:
        try:
            yield from self._frames()
        finally:
            self.close()

    def _frames(self) -> Iterator[StereoFrame]:
        raise NotImplementedError

    def close(self) -> None:
        """Release files and devices (safe to call twice)."""

    def __enter__(self) -> StereoSource:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _frame_name(index: int) -> str:
    return f"frame_{index:06d}"


def _bgr_to_rgb(image: np.ndarray) -> np.ndarray:
    if image.ndim == 2:
        return cv2.cvtColor(image, cv2.COLOR_GRAY2RGB)
    return cv2.cvtColor(image, cv2.COLOR_BGR2RGB)


def _open_video(path: str | os.PathLike[str]) -> cv2.VideoCapture:
    p = Path(path)
    if p.is_dir():
        example = (f" ('{p}/frame_*/left.png' '{p}/frame_*/right.png' for a rendered sequence)"
                   if any(p.glob("frame_*/left.png")) else "")
        raise InputFileError(f"{p} is a folder, not a video file; a stereo pair of image sequences is two folders "
                             f"or two glob patterns of images{example}")
    if not p.is_file():
        raise InputFileError(f"video file {p} does not exist")
    capture = cv2.VideoCapture(str(p))
    if not capture.isOpened():
        capture.release()
        raise InputFileError(f"{p}: cannot be opened as a video (unknown container or codec)")
    return capture


def _frame_count(capture: cv2.VideoCapture) -> int | None:
    count = int(capture.get(cv2.CAP_PROP_FRAME_COUNT))
    return count if count > 0 else None


def _video_fps(capture: cv2.VideoCapture) -> float:
    fps = capture.get(cv2.CAP_PROP_FPS)
    return float(fps) if fps and np.isfinite(fps) and fps > 0 else 30.0


class VideoPairSource(StereoSource):
    """Two video files, left and right, read in step.

    Raises
    ------
    InputFileError
        A file is missing or cannot be opened as a video.
    ImageMismatchError
        The two videos state different frame counts or frame sizes.
    """

    def __init__(self, left_path: str | os.PathLike[str], right_path: str | os.PathLike[str]) -> None:
        self.description = f"videos {left_path} and {right_path}"
        self._left = _open_video(left_path)
        try:
            self._right = _open_video(right_path)
        except InputFileError:
            self._left.release()
            raise
        self.fps = _video_fps(self._left)
        counts = (_frame_count(self._left), _frame_count(self._right))
        sizes = [(int(c.get(cv2.CAP_PROP_FRAME_WIDTH)), int(c.get(cv2.CAP_PROP_FRAME_HEIGHT)))
                 for c in (self._left, self._right)]
        if None not in counts and counts[0] != counts[1]:
            self.close()
            raise ImageMismatchError(f"{left_path} has {counts[0]} frames but {right_path} has {counts[1]}; "
                                     f"a stereo video pair needs the same number")
        if sizes[0] != sizes[1]:
            self.close()
            raise ImageMismatchError(f"{left_path} is {sizes[0][0]}x{sizes[0][1]} but {right_path} is "
                                     f"{sizes[1][0]}x{sizes[1][1]}")
        self.total_frames = counts[0]

    def _frames(self) -> Iterator[StereoFrame]:
        index = 0
        while True:
            ok_left, left = self._left.read()
            ok_right, right = self._right.read()
            if not (ok_left and ok_right):
                return
            yield StereoFrame(index, index / self.fps, _bgr_to_rgb(left), _bgr_to_rgb(right), _frame_name(index))
            index += 1

    def close(self) -> None:
        """Release both videos."""
        for capture in (getattr(self, "_left", None), getattr(self, "_right", None)):
            if capture is not None:
                capture.release()


class SideBySideSource(StereoSource):
    """One video with the left view in the left half of each frame and the right view in the right half.

    Raises
    ------
    InputFileError
        The file is missing or not a video.
    ImageMismatchError
        The frame width is odd (the halves cannot be equal).
    """

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.description = f"side-by-side video {path}"
        self._capture = _open_video(path)
        width = int(self._capture.get(cv2.CAP_PROP_FRAME_WIDTH))
        if width % 2:
            self.close()
            raise ImageMismatchError(f"{path}: frame width {width} is odd; a side-by-side video holds two "
                                     f"views of equal width")
        self.fps = _video_fps(self._capture)
        self.total_frames = _frame_count(self._capture)

    def _frames(self) -> Iterator[StereoFrame]:
        index = 0
        while True:
            ok, frame = self._capture.read()
            if not ok:
                return
            half = frame.shape[1] // 2
            yield StereoFrame(index, index / self.fps, _bgr_to_rgb(np.ascontiguousarray(frame[:, :half])),
                              _bgr_to_rgb(np.ascontiguousarray(frame[:, half:])), _frame_name(index))
            index += 1

    def close(self) -> None:
        """Release the video."""
        capture = getattr(self, "_capture", None)
        if capture is not None:
            capture.release()


def natural_key(text: str) -> list:
    """A sort key that orders the numbers in ``text`` by value (``left2`` before ``left11``)."""
    return [int(part) if part.isdigit() else part.lower() for part in re.split(r"(\d+)", text)]


def _list_images(spec: str | os.PathLike[str], side: str) -> list[Path]:
    """The image files a folder or glob pattern names, in natural order of their whole paths (a
    pattern may cover one folder per frame: ``frame_*/left.png``)."""
    text = str(spec)
    if Path(text).is_dir():
        files = [p for p in Path(text).iterdir() if p.is_file() and p.suffix.lower() in IMAGE_EXTENSIONS]
    elif glob.has_magic(text):
        files = [Path(p) for p in glob.glob(text) if Path(p).is_file()]
    elif not os.path.exists(text):
        raise InputFileError(f"{side} image sequence {text} does not exist (a folder of images or a glob pattern)")
    else:
        raise InputFileError(f"{side} image sequence {text}: not a folder and not a glob pattern")
    if not files:
        raise InputFileError(f"{side} image sequence {text}: no image files")
    return sorted(files, key=lambda path: natural_key(path.as_posix()))


def relative_paths(files: list[Path]) -> list[str]:
    """Each file's path below the folder common to all (``frame_0003/left.png``; the file name
    when all lie in one folder): what the two sides are paired by."""
    common = Path(os.path.commonpath([p.parent for p in files])) if len(files) > 1 else files[0].parent
    return [p.relative_to(common).as_posix() for p in files]


def _file_frame_name(relative_path: str) -> str:
    """A frame's name for per-frame outputs: its relative path without the ending, ``/`` as
    ``_`` (``frame_0003_left``)."""
    return os.path.splitext(relative_path)[0].replace("/", "_")


def first_out_of_step(left_names: list[str], right_names: list[str]) -> int | None:
    """Index of the first pair (paired by order) whose frame numbers are out of step with the
    first pair's, or None.

    A name's frame number is all its digits read as one number: ``cam0_0012`` 12,
    ``0012_cam0`` 120, ``1305031102.885000`` and ROS's ``1680000000_003000000`` one timestamp
    each (fixed-width fields, as cameras write them). Its difference between the right and the
    left name may be anything (``cam0_12`` with ``cam1_12``, ``left_0012`` with ``right_1012``),
    but must stay that of the first pair within half the sequence's typical step: per-camera
    timestamps that differ by a little jitter keep in step; a frame missing on one side does
    not. Names without digits are not judged."""
    numbers = ["".join(re.findall(r"\d+", os.path.splitext(name)[0])) for name in left_names + right_names]
    if len(left_names) < 2 or not all(numbers):
        return None
    left_values, right_values = [int(n) for n in numbers[:len(left_names)]], [int(n) for n in numbers[len(left_names):]]
    step = np.median([abs(b - a) for a, b in zip(left_values[:-1], left_values[1:])])
    if step == 0:
        return None
    offsets = [r - l for l, r in zip(left_values, right_values)]
    out_of_step = [abs(o - offsets[0]) > step / 2 for o in offsets]
    return out_of_step.index(True) if any(out_of_step) else None


def _paired(left_files: list[Path], right_files: list[Path], left: object, right: object) -> list[tuple[int, int]]:
    """Indices ``(i, j)`` of the left and right files that form the frames, in order.

    Both sides with the same names: by name. At least half of the names in common but not all:
    refused (a frame missing on one side would pair every later frame with the wrong partner).
    Fewer in common (per-camera timestamps that meet by chance) or none: by order, the counts
    equal; a warning when the frame numbers in the paired names
    fall out of step (:func:`first_out_of_step`: a frame may be missing)."""
    left_names, right_names = relative_paths(left_files), relative_paths(right_files)
    right_index = {name: j for j, name in enumerate(right_names)}
    common = right_index.keys() & set(left_names)
    if common and len(common) == len(left_names) == len(right_names):
        logger.info("pairing %d images by name", len(left_names))
        return [(i, right_index[name]) for i, name in enumerate(left_names)]
    if 2 * len(common) >= min(len(left_names), len(right_names)):     # one naming, a frame missing
        unpaired = [f"{left_files[i]}" for i, name in enumerate(left_names) if name not in common][:1] + \
                   [f"{right_files[j]}" for j, name in enumerate(right_names) if name not in common][:1]
        raise ImageMismatchError(f"{left} and {right} share {len(common)} image names but not all "
                                 f"({' and '.join(unpaired)} {'have' if len(unpaired) > 1 else 'has'} no partner of "
                                 f"the same name): a frame missing on one side would pair the later ones wrongly")
    if len(left_files) != len(right_files):
        raise ImageMismatchError(f"{left} holds {len(left_files)} images but {right} holds "
                                 f"{len(right_files)}, and their names differ, so they cannot be paired")
    out_of_step = first_out_of_step(left_names, right_names)
    if out_of_step is not None:
        logger.warning("pairing the images by order, but %s goes with %s: their frame numbers are out of step "
                       "with the first pair's (is a frame missing on one side?)", left_files[out_of_step],
                       right_files[out_of_step])
    logger.info("pairing %d images by sorted order", len(left_files))
    return [(i, i) for i in range(len(left_files))]


class ImageSequenceSource(StereoSource):
    """Two image sequences (folders or glob patterns), paired by file name or by order.

    Parameters
    ----------
    left, right
        Folders (images with the endings in :data:`IMAGE_EXTENSIONS`) or glob patterns.
    fps : float
        Frame rate for the timestamps, frames per second.

    Raises
    ------
    InputFileError
        A folder or pattern names no images.
    ImageMismatchError
        The two sides share at least half their names but not all, or fewer and their counts
        differ.
    """

    def __init__(self, left: str | os.PathLike[str], right: str | os.PathLike[str], *, fps: float = 30.0) -> None:
        if not (np.isfinite(fps) and fps > 0):
            raise InvalidInputError(f"fps must be > 0, got {fps}")
        self.description = f"image sequences {left} and {right}"
        left_files, right_files = _list_images(left, "left"), _list_images(right, "right")
        relative = relative_paths(left_files)
        names = [_file_frame_name(path) for path in relative]
        if len(set(names)) < len(names):            # one stem with two endings: the outputs need one name each
            names = [path.replace("/", "_") for path in relative]
        self._pairs = [(left_files[i], right_files[j], names[i]) for i, j in _paired(left_files, right_files, left, right)]
        self.fps = float(fps)
        self.total_frames = len(self._pairs)

    def _frames(self) -> Iterator[StereoFrame]:
        for index, (left_path, right_path, name) in enumerate(self._pairs):
            left = read_image(left_path, mode="color")
            right = read_image(right_path, mode="color")
            for path, image in ((left_path, left), (right_path, right)):
                if image.dtype != np.uint8:
                    raise InputFileError(f"{path}: expected an 8-bit image, got {image.dtype}")
            check_pair_of_files(left, right, left_path, right_path)
            yield StereoFrame(index, index / self.fps, left, right, name)


class CameraPairSource(StereoSource):
    """Two live cameras by device index (``cv2.VideoCapture(index)``).

    Parameters
    ----------
    left_index, right_index : int
        Device indices (``/dev/video<i>`` on Linux).
    size : (int, int), optional
        Requested frame size ``(width, height)``; drivers may ignore it.

    Raises
    ------
    InputFileError
        A camera cannot be opened.
    """

    is_live = True

    def __init__(self, left_index: int, right_index: int, *, size: tuple[int, int] | None = None) -> None:
        if left_index == right_index:
            raise InvalidInputError(f"left and right cameras must differ, got device {left_index} twice")
        self.description = f"cameras {left_index} and {right_index}"
        self._captures: list[cv2.VideoCapture] = []
        for index in (left_index, right_index):
            capture = cv2.VideoCapture(int(index))
            if not capture.isOpened():
                capture.release()
                self.close()
                raise InputFileError(f"camera {index} cannot be opened (no such device, or busy)")
            if size is not None:
                capture.set(cv2.CAP_PROP_FRAME_WIDTH, size[0])
                capture.set(cv2.CAP_PROP_FRAME_HEIGHT, size[1])
            self._captures.append(capture)
        self.fps = _video_fps(self._captures[0])

    def _frames(self) -> Iterator[StereoFrame]:
        start = time.monotonic()
        index = 0
        while True:
            if not all(capture.grab() for capture in self._captures):
                logger.warning("a camera stopped delivering frames after %d frames", index)
                return
            stamp = time.monotonic() - start
            images = []
            for capture in self._captures:
                ok, image = capture.retrieve()
                if not ok:
                    logger.warning("a camera frame could not be decoded after %d frames", index)
                    return
                images.append(_bgr_to_rgb(image))
            yield StereoFrame(index, stamp, images[0], images[1], _frame_name(index))
            index += 1

    def close(self) -> None:
        """Release both cameras."""
        for capture in getattr(self, "_captures", []):
            capture.release()


def _is_video_file(text: str) -> bool:
    return Path(text).is_file() and Path(text).suffix.lower() not in IMAGE_EXTENSIONS


def open_source(sources: Sequence[str], *, kind: str = "auto", fps: float = 30.0) -> StereoSource:
    """Open the stereo source that command-line arguments describe.

    Parameters
    ----------
    sources : sequence of str
        One video file (side by side), two video files, two folders or glob patterns of
        images, or two camera device indices.
    kind : {"auto", "videos", "images", "side-by-side", "cameras"}
        ``auto``: one argument is a side-by-side video; two integers are cameras; two files
        that are not images are videos; anything else is two image sequences.
    fps : float
        Frame rate assumed for image sequences (timestamps).

    Returns
    -------
    StereoSource

    Raises
    ------
    InvalidInputError
        Wrong number of arguments for the kind, or an unknown kind.
    InputFileError, ImageMismatchError
        From the source itself.
    """
    if kind not in SOURCE_KINDS:
        raise InvalidInputError(f"kind must be one of {list(SOURCE_KINDS)}, got {kind!r}")
    sources = [str(s) for s in sources]
    if kind == "auto":
        missing = [s for s in sources if not s.isdigit() and not glob.has_magic(s) and not os.path.exists(s)]
        if missing:                 # named, not taken for an image sequence beside a video (review)
            raise InputFileError(f"{missing[0]} does not exist (a video file, a folder of images, a glob pattern "
                                 f"or a camera index was expected)")
        if len(sources) == 1:
            kind = "side-by-side"
        elif len(sources) == 2 and all(s.isdigit() for s in sources):
            kind = "cameras"
        elif len(sources) == 2 and all(_is_video_file(s) for s in sources):
            kind = "videos"
        else:
            kind = "images"
    expected = 1 if kind == "side-by-side" else 2
    if len(sources) != expected:
        raise InvalidInputError(f"a {kind} source takes {'one argument' if expected == 1 else 'two arguments'}, "
                                f"got {len(sources)}: {' '.join(sources)}")
    if kind == "side-by-side":
        return SideBySideSource(sources[0])
    if kind in ("videos", "images"):
        refuse_one_file_twice(sources[0], sources[1])
    if kind == "videos":
        return VideoPairSource(sources[0], sources[1])
    if kind == "cameras":
        if not all(s.isdigit() for s in sources):
            raise InvalidInputError(f"cameras are given by device index (integers), got {' '.join(sources)}")
        return CameraPairSource(int(sources[0]), int(sources[1]))
    return ImageSequenceSource(sources[0], sources[1], fps=fps)
