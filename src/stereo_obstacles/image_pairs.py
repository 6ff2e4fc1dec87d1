"""The one check every stereo stage makes first: the two images of a pair have one size (and, as
read from files, one type)."""

from __future__ import annotations

import os

import numpy as np

from stereo_obstacles.errors import ImageMismatchError


def check_same_size(left: np.ndarray, right: np.ndarray) -> None:
    """Raise :class:`ImageMismatchError` when ``left`` and ``right`` differ in height or width.

    Both are arrays of shape ``(H, W)`` or ``(H, W, C)``; channels are not compared.
    """
    if left.shape[:2] != right.shape[:2]:
        raise ImageMismatchError(f"left and right images differ in size: {left.shape[1]}x{left.shape[0]} "
                                 f"and {right.shape[1]}x{right.shape[0]}")


def check_pair_of_files(left: np.ndarray, right: np.ndarray, left_name: object, right_name: object, *,
                        channels: bool = True) -> None:
    """Raise :class:`ImageMismatchError` naming the files ``left_name`` and ``right_name`` when the
    images read from them differ in size, in type (8 or 16 bits) or, with ``channels``, one grey
    and one in colour: ``"L is 640x480 but R is 320x240; a stereo pair needs one size"``."""
    if left.shape[:2] != right.shape[:2]:
        raise ImageMismatchError(f"{left_name} is {left.shape[1]}x{left.shape[0]} but {right_name} is "
                                 f"{right.shape[1]}x{right.shape[0]}; a stereo pair needs one size")
    if left.dtype != right.dtype:
        raise ImageMismatchError(f"{left_name} is {left.dtype} but {right_name} is {right.dtype}")
    if channels and left.shape != right.shape:
        raise ImageMismatchError(f"{left_name} is {_kind(left)} but {right_name} is {_kind(right)}")


def _kind(image: np.ndarray) -> str:
    return "grey" if image.ndim == 2 or image.shape[2] == 1 else f"{image.shape[2]}-channel"


def refuse_one_file_twice(left_name: str | os.PathLike[str], right_name: str | os.PathLike[str]) -> None:
    """Raise :class:`ImageMismatchError` when the two files (or folders of frames) of a pair are one
    (given twice, or by two names): the two cameras' images are needed, and an image matched with itself says only
    that nothing stands anywhere. Two files of equal content are not refused: two cameras facing a
    blank wall may deliver two equal uniform images."""
    try:
        same = os.path.samefile(left_name, right_name)
    except OSError:
        return                                  # a missing file is reported when it is read
    if same:
        raise ImageMismatchError(f"{left_name} and {right_name} are one and the same; a stereo pair needs the two "
                                 f"cameras' images")
