"""Argument types shared by several sub-commands (sizes, counts)."""

from __future__ import annotations

import argparse
import math
import re

MIN_IMAGE_SIDE_PX = 16
MAX_IMAGE_SIDE_PX = 8192


def image_size(text: str) -> tuple[int, int]:
    """Parse ``WxH`` (e.g. ``640x480``) into ``(width, height)`` pixels.

    Raises
    ------
    InvalidInputError
        Not of the form ``WxH``, or a side outside 16..8192 pixels.
    """
    from stereo_obstacles.errors import InvalidInputError

    match = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if match is None:
        raise InvalidInputError(f"--size must look like 640x480, got {text!r}")
    width, height = int(match.group(1)), int(match.group(2))
    if not (MIN_IMAGE_SIDE_PX <= width <= MAX_IMAGE_SIDE_PX and MIN_IMAGE_SIDE_PX <= height <= MAX_IMAGE_SIDE_PX):
        raise InvalidInputError(f"--size must be between {MIN_IMAGE_SIDE_PX}x{MIN_IMAGE_SIDE_PX} and "
                                f"{MAX_IMAGE_SIDE_PX}x{MAX_IMAGE_SIDE_PX} pixels, got {width}x{height}")
    return width, height


def output_path(text: str) -> str:
    """argparse type: a file or folder to write, not empty (an empty name would write into the
    current folder, or nowhere)."""
    if not text.strip():
        raise argparse.ArgumentTypeError(f"expected a path to write to, got {text!r}")
    return text


def _integer_at_least(text: str, lowest: int, what: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None
    if value < lowest:
        raise argparse.ArgumentTypeError(f"expected {what}, got {value}")
    return value


def positive_int(text: str) -> int:
    """argparse type: an integer >= 1."""
    return _integer_at_least(text, 1, "a positive integer")


def non_negative_int(text: str) -> int:
    """argparse type: an integer >= 0."""
    return _integer_at_least(text, 0, "an integer >= 0")


def jpeg_quality(text: str) -> int:
    """argparse type: a JPEG quality, an integer in 1..100."""
    value = _integer_at_least(text, 1, "a JPEG quality 1..100")
    if value > 100:
        raise argparse.ArgumentTypeError(f"expected a JPEG quality 1..100, got {value}")
    return value


def positive_metres(text: str) -> float:
    """argparse type: a finite length > 0, metres."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected metres > 0, got {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"expected metres > 0, got {value}")
    return value


def noise_levels(text: str) -> float:
    """argparse type: sensor noise in grey levels, a number in 0..50."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected grey levels 0..50, got {text!r}") from None
    if not 0.0 <= value <= 50.0:  # also refuses NaN
        raise argparse.ArgumentTypeError(f"expected grey levels 0..50, got {value}")
    return value
