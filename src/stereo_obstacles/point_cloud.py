"""Coloured 3-D point clouds as binary little-endian PLY files.

Each vertex is ``float x, y, z`` (metres, the rectified left camera frame: x right, y down,
z forward) and ``uchar red, green, blue``, 15 bytes, the layout Open3D, MeshLab and
CloudCompare read. The header's comments state the frame and the units. Points with a NaN or
infinite coordinate (pixels without depth) are left out.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from stereo_obstacles import __version__
from stereo_obstacles.atomic import write_bytes_atomic
from stereo_obstacles.errors import InputFileError, InvalidInputError

FRAME_COMMENT = "frame: rectified left camera, x right, y down, z forward, origin at its optical centre"
UNITS_COMMENT = "units: metres"

_VERTEX = np.dtype([("x", "<f4"), ("y", "<f4"), ("z", "<f4"),
                    ("red", "u1"), ("green", "u1"), ("blue", "u1")])
_PROPERTIES = [("float", "x"), ("float", "y"), ("float", "z"),
               ("uchar", "red"), ("uchar", "green"), ("uchar", "blue")]
_MAX_HEADER_BYTES = 64 * 1024


@dataclass(frozen=True)
class PointCloud:
    """Points read from a PLY file.

    Attributes
    ----------
    points : numpy.ndarray
        ``float32 (N, 3)`` coordinates in metres.
    colours : numpy.ndarray
        ``uint8 (N, 3)`` RGB.
    comments : tuple of str
        The header's comment lines, without the ``comment`` keyword.
    """

    points: np.ndarray
    colours: np.ndarray
    comments: tuple[str, ...] = ()


def write_ply(path: str | os.PathLike[str], points: np.ndarray, colours: np.ndarray, *,
              comments: Sequence[str] = ()) -> Path:
    """Write coloured points as a binary little-endian PLY file (atomically); skip non-finite points.

    Parameters
    ----------
    path
        Destination file (``.ply``).
    points
        ``float (N, 3)`` or ``(H, W, 3)`` coordinates in metres in the left camera frame (for
        example :func:`stereo_obstacles.depth.points_from_depth`); points with any NaN or
        infinite coordinate are not written.
    colours
        ``uint8`` RGB of the same shape as ``points`` (for example the left image).
    comments
        Extra header comment lines (single lines of ASCII text).

    Returns
    -------
    pathlib.Path
        The written file.

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> pts = np.array([[0.0, 0.0, 1.0], [np.nan, 0.0, 2.0]], np.float32)
    >>> rgb = np.array([[255, 0, 0], [0, 255, 0]], np.uint8)
    >>> len(read_ply(write_ply(folder / "p.ply", pts, rgb)).points)
    1
    """
    p = np.asarray(points)
    c = np.asarray(colours)
    if p.ndim not in (2, 3) or p.shape[-1] != 3:
        raise InvalidInputError(f"points must be (N, 3) or (H, W, 3), got shape {p.shape}")
    if not np.issubdtype(p.dtype, np.floating):
        raise InvalidInputError(f"points must be floating point (NaN = no point), got {p.dtype}")
    if c.shape != p.shape:
        raise InvalidInputError(f"colours must have the shape of points {p.shape}, got {c.shape}")
    if c.dtype != np.uint8:
        raise InvalidInputError(f"colours must be uint8 RGB, got {c.dtype}")
    for line in comments:
        if not line.isascii() or "\n" in line or "\r" in line:
            raise InvalidInputError(f"PLY comments must be single lines of ASCII text, got {line!r}")
    p = p.reshape(-1, 3)
    c = c.reshape(-1, 3)
    keep = np.isfinite(p).all(axis=1)
    vertices = np.empty(int(keep.sum()), dtype=_VERTEX)
    for i, name in enumerate(("x", "y", "z")):
        vertices[name] = p[keep, i]
    for i, name in enumerate(("red", "green", "blue")):
        vertices[name] = c[keep, i]
    all_comments = [f"written by stereo-obstacles {__version__}", FRAME_COMMENT, UNITS_COMMENT, *comments]
    header = ["ply", "format binary_little_endian 1.0", *(f"comment {line}" for line in all_comments),
              f"element vertex {len(vertices)}", *(f"property {kind} {name}" for kind, name in _PROPERTIES),
              "end_header"]
    return write_bytes_atomic(path, ("\n".join(header) + "\n").encode("ascii") + vertices.tobytes())


def _read_header(data: bytes, source: str) -> tuple[list[str], int]:
    """The header lines and the offset of the binary payload."""
    if not data.startswith(b"ply\n") and not data.startswith(b"ply\r\n"):
        raise InputFileError(f"{source} is not a PLY file (it does not start with 'ply')")
    end = data.find(b"end_header", 0, _MAX_HEADER_BYTES)
    newline = data.find(b"\n", end) if end >= 0 else -1
    if newline < 0:
        raise InputFileError(f"{source}: PLY header has no end_header line")
    try:
        text = data[:newline].decode("ascii")
    except UnicodeDecodeError as exc:
        raise InputFileError(f"{source}: PLY header is not ASCII text") from exc
    return [line.strip() for line in text.splitlines()], newline + 1


def read_ply(path: str | os.PathLike[str]) -> PointCloud:
    """Read a PLY file written by :func:`write_ply`.

    Only the layout :func:`write_ply` writes is accepted: binary little-endian, one ``vertex``
    element with ``float x, y, z`` and ``uchar red, green, blue``, nothing else.

    Raises
    ------
    InputFileError
        The file is missing, is not a PLY file, has another layout, or is truncated.
    """
    source = str(path)
    try:
        data = Path(path).read_bytes()
    except FileNotFoundError as exc:
        raise InputFileError(f"point cloud {source} does not exist") from exc
    except OSError as exc:
        raise InputFileError(f"cannot read point cloud {source}: {exc.strerror or exc}") from exc
    lines, offset = _read_header(data, source)
    comments = tuple(line[len("comment"):].strip() for line in lines if line.split()[:1] == ["comment"])
    body = [line for line in lines[1:-1] if line and line.split()[0] not in ("comment", "obj_info")]
    if not body or body[0] != "format binary_little_endian 1.0":
        found = body[0] if body else "nothing"
        raise InputFileError(f"{source}: only binary_little_endian 1.0 PLY files are read, found {found!r}")
    elements = [line.split() for line in body[1:] if line.startswith("element")]
    if len(elements) != 1 or elements[0][1] != "vertex" or len(elements[0]) != 3 or not elements[0][2].isdigit():
        raise InputFileError(f"{source}: expected one 'element vertex N', found {[' '.join(e) for e in elements]}")
    properties = [tuple(line.split()[1:]) for line in body[2:]]
    if properties != _PROPERTIES:
        raise InputFileError(f"{source}: expected vertex properties float x, y, z and uchar red, green, blue; "
                             f"found {', '.join(' '.join(p) for p in properties) or 'none'}")
    count = int(elements[0][2])
    expected = count * _VERTEX.itemsize
    if len(data) - offset < expected:
        raise InputFileError(f"{source} is truncated: {len(data) - offset} bytes of vertices, {expected} expected")
    vertices = np.frombuffer(data, dtype=_VERTEX, count=count, offset=offset)
    points = np.stack([vertices[n] for n in ("x", "y", "z")], axis=1).astype(np.float32)
    colours = np.stack([vertices[n] for n in ("red", "green", "blue")], axis=1).astype(np.uint8)
    return PointCloud(points=points, colours=colours, comments=comments)


__all__ = ["PointCloud", "write_ply", "read_ply", "FRAME_COMMENT", "UNITS_COMMENT"]
