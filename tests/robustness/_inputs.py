"""Small files the robustness tests feed to the commands: a synthetic pair and broken variants."""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import cv2
import numpy as np

PAIR_SIZE = (160, 120)
"""Width and height of the synthetic pair, pixels (small: the suite must stay fast)."""


def write_png_chunks(path: Path, width: int, height: int, colour_type: int, rows: bytes,
                     palette: bytes | None = None) -> Path:
    """Write an 8-bit PNG by hand (OpenCV cannot write palette images or lying headers)."""
    def chunk(kind: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)

    data = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, colour_type, 0, 0, 0))
    if palette is not None:
        data += chunk(b"PLTE", palette)
    path.write_bytes(data + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))
    return path


def palette_png(path: Path, rgb: np.ndarray, colours: int = 16) -> Path:
    """``rgb`` quantised to ``colours`` and written as a palette (colour type 3) PNG."""
    h, w = rgb.shape[:2]
    levels = np.linspace(0, 255, colours).astype(np.uint8)
    grey = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY)
    index = np.clip(np.rint(grey / 255 * (colours - 1)), 0, colours - 1).astype(np.uint8)
    palette = np.stack([levels, levels[::-1], np.roll(levels, colours // 2)], axis=1).tobytes()
    rows = b"".join(b"\x00" + index[y].tobytes() for y in range(h))
    return write_png_chunks(path, w, h, 3, rows, palette)


def write_rgb(path: Path, rgb: np.ndarray) -> Path:
    """Write an RGB (or grey, or 16-bit) array with OpenCV's BGR order handled."""
    array = cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR) if rgb.ndim == 3 and rgb.shape[2] == 3 else rgb
    if not cv2.imwrite(str(path), array):
        raise OSError(f"could not write {path}")
    return path


def error_line(err: str) -> str:
    """The single ``stereo-obstacles: error: ...`` line of stderr (asserting there is one)."""
    lines = [line for line in err.splitlines() if line.startswith("stereo-obstacles: error:")]
    assert len(lines) == 1, err
    return lines[0]
