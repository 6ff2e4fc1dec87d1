"""How much memory matching a pair needs, and the largest images accepted.

Matching allocates per-pixel tables (window statistics of both images, the growth record of
each pixel, the candidate table, the disparity and similarity maps), so its memory grows with
``W * H``. Rather than let the operating system kill the process half-way, :func:`match`
(:mod:`stereo_obstacles.matching`) refuses images whose estimate exceeds the documented bound
or the memory available now, with the figures in the message (``docs/robustness.md``).
"""

from __future__ import annotations

import logging
import os

from stereo_obstacles.errors import InvalidInputError

logger = logging.getLogger(__name__)

MATCH_BYTES_PER_PIXEL = 256
"""Estimated peak memory of one match, bytes per pixel of the image. Measured: 183 B/px at
3200x2400 and 199 B/px at 1600x1200 above the loaded images (textured pairs, default
options), rounded up for the input copies and weak texture's longer candidate lists."""

MAX_MATCH_PIXELS = 64_000_000
"""Largest image accepted for matching, pixels (W * H): about 16 GB by the estimate."""


def matching_memory_bytes(width_px: int, height_px: int) -> int:
    """Estimated peak memory of matching a ``width_px`` x ``height_px`` pair, bytes."""
    return MATCH_BYTES_PER_PIXEL * int(width_px) * int(height_px)


def available_memory_bytes() -> int | None:
    """Memory the system can give now (Linux ``MemAvailable``), bytes; ``None`` when unknown."""
    try:
        with open("/proc/meminfo", encoding="ascii") as handle:
            for line in handle:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def check_matching_size(width_px: int, height_px: int, *, available_bytes: int | None = None) -> None:
    """Refuse a pair too large to match, naming the memory it would need.

    Parameters
    ----------
    width_px, height_px : int
        Image size, pixels.
    available_bytes : int, optional
        Memory available, bytes; default :func:`available_memory_bytes` (no check when unknown).

    Raises
    ------
    InvalidInputError
        Above :data:`MAX_MATCH_PIXELS`, or an estimate above the available memory.
    """
    pixels = int(width_px) * int(height_px)
    need = matching_memory_bytes(width_px, height_px)
    if pixels > MAX_MATCH_PIXELS:
        raise InvalidInputError(
            f"left, right: {width_px}x{height_px} images ({pixels / 1e6:.0f} Mpx) exceed the matching limit of "
            f"{MAX_MATCH_PIXELS / 1e6:.0f} Mpx (matching would need about {need / 1e9:.1f} GB); shrink them first")
    available = available_memory_bytes() if available_bytes is None else available_bytes
    if available is not None and need > available:
        raise InvalidInputError(
            f"left, right: matching {width_px}x{height_px} images needs about {need / 1e9:.1f} GB but only "
            f"{available / 1e9:.1f} GB of memory is available; shrink the images or free memory")
    logger.debug("matching %dx%d needs about %.2f GB", width_px, height_px, need / 1e9)
