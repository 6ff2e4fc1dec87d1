"""Reading and writing the files people use for stereo: images, disparity, depth, labels.

In memory the conventions are fixed:

* colour images are ``uint8`` (or ``uint16``) arrays of shape ``(H, W, 3)`` in **RGB** order,
  grey images ``(H, W)``;
* a disparity map is ``float32`` of shape ``(H, W)`` in pixels, with **NaN** where there is
  no disparity (left pixel ``(x, y)`` matches right pixel ``(x - d, y)``);
* a depth map is ``float32`` metres, NaN where unknown;
* a label image is ``uint8`` ``(H, W)``.

On disk the formats are the ones stereo benchmarks use: PFM (little-endian, rows bottom to
top, ``+inf`` = invalid), KITTI 16-bit PNG (``round(d * 256)``, 0 = invalid), ``.npy`` float32
(NaN = invalid); depth as ``.npy`` metres or 16-bit PNG millimetres (0 = invalid, ROS REP 118).
Every writer is atomic (see :mod:`stereo_obstacles.atomic`) and every reader raises
:class:`~stereo_obstacles.errors.InputFileError` with the file name on bad input.
"""

from __future__ import annotations

import io
import os
import re
import tokenize
from pathlib import Path

import cv2
import numpy as np

from stereo_obstacles.atomic import write_bytes_atomic
from stereo_obstacles.errors import InputFileError, InvalidInputError, OutputError
from stereo_obstacles.float_maps import check_float_map

PathLike = str | os.PathLike[str]

KITTI_DISPARITY_SCALE = 256.0
"""KITTI stores ``round(disparity * 256)`` in a 16-bit PNG."""

KITTI_MAX_DISPARITY = (np.iinfo(np.uint16).max) / KITTI_DISPARITY_SCALE
"""The largest disparity a KITTI PNG can hold, in pixels (about 255.996)."""

_IMAGE_SUFFIXES = {".png", ".jpg", ".jpeg", ".bmp", ".ppm", ".pgm", ".pbm", ".tif", ".tiff",
                   ".webp"}


def _read_file_bytes(path: PathLike, what: str) -> bytes:
    p = Path(path)
    if not p.exists():
        raise InputFileError(f"{what} {p} does not exist")
    if p.is_dir():
        raise InputFileError(f"{what} {p} is a folder, not a file")
    if not p.is_file():  # a pipe would block the read forever, a device never end it
        raise InputFileError(f"{what} {p} is not a regular file (a pipe or a device?)")
    try:
        data = p.read_bytes()
    except OSError as exc:
        raise InputFileError(f"cannot read {what} {p}: {exc.strerror or exc}") from exc
    if not data:
        raise InputFileError(f"{what} {p} is empty")
    return data


def read_image(path: PathLike, *, mode: str = "any") -> np.ndarray:
    """Read an image file.

    Parameters
    ----------
    path
        Any format OpenCV decodes (PNG, JPEG, PPM/PGM, BMP, TIFF, WebP).
    mode
        ``"any"``: keep grey as ``(H, W)`` and colour as ``(H, W, 3)`` RGB, keep 16-bit depth;
        ``"color"``: require a colour image, return ``(H, W, 3)`` RGB (an alpha channel is
        dropped, a palette image expanded); ``"gray"``: return ``(H, W)``, converting colour
        to grey with the ITU-R BT.601 weights.

    Returns
    -------
    numpy.ndarray
        ``uint8`` or ``uint16`` image.

    Raises
    ------
    InputFileError
        Missing, empty or undecodable file, or a grey image when ``mode="color"``.
    """
    if mode not in ("any", "color", "gray"):
        raise InvalidInputError(f"mode must be 'any', 'color' or 'gray', got {mode!r}")
    data = _read_file_bytes(path, "image")
    buffer = np.frombuffer(data, dtype=np.uint8)
    flag = cv2.IMREAD_GRAYSCALE if mode == "gray" else cv2.IMREAD_UNCHANGED
    try:
        image = cv2.imdecode(buffer, flag)
    except cv2.error as exc:  # a header claiming more than OpenCV's pixel limit, for example
        raise InputFileError(f"{path} cannot be decoded: {_opencv_reason(exc)}") from exc
    if image is None:
        raise InputFileError(f"{path} is not an image OpenCV can decode (truncated or wrong format?)")
    if image.dtype not in (np.uint8, np.uint16):
        raise InputFileError(f"{path}: unsupported pixel type {image.dtype} (expected 8 or 16 bit)")
    if image.ndim == 3 and image.shape[2] == 1:
        image = image[:, :, 0]
    if image.ndim == 3:
        code = cv2.COLOR_BGRA2RGB if image.shape[2] == 4 else cv2.COLOR_BGR2RGB
        image = cv2.cvtColor(image, code)
        if mode == "color" and _is_grey_content(image):
            raise InputFileError(f"{path} is a grey image stored as colour; a colour image is needed")
    elif mode == "color":
        raise InputFileError(f"{path} is a grey image; a colour image is needed")
    return np.ascontiguousarray(image)


def _opencv_reason(exc: cv2.error) -> str:
    """The human part of an OpenCV error (its assertion text), on one line."""
    text = " ".join(str(exc).split())
    if "CV_IO_MAX_IMAGE_PIXELS" in text or "CV_IO_MAX_IMAGE_WIDTH" in text or "CV_IO_MAX_IMAGE_HEIGHT" in text:
        return "its header claims a size beyond OpenCV's decoding limit (2^30 pixels, sides up to 2^20)"
    found = re.search(r"\(-\d+:[^)]*\) (.*?) in function", text)
    return found.group(1) if found else text


def to_uint8(*images: np.ndarray) -> tuple[np.ndarray, ...]:
    """The images as 8-bit, 16-bit ones scaled down together by their significant bits.

    Parameters
    ----------
    *images : ndarray of uint8 or uint16, shape (H, W) or (H, W, 3)
        Images that belong together (a stereo pair); 8-bit ones are returned unchanged.

    Returns
    -------
    tuple of ndarray of uint8
        Same shapes. 16-bit images are shifted right by ``bits - 8``, ``bits`` being the bit
        length of the brightest pixel of them all (at least 8), so 12-bit data keeps its contrast
        and both images of a pair keep the same scale.

    Raises
    ------
    InvalidInputError
        An image that is neither ``uint8`` nor ``uint16``.
    """
    arrays = [np.asarray(image) for image in images]
    for array in arrays:
        if array.dtype not in (np.uint8, np.uint16):
            raise InvalidInputError(f"images must be uint8 or uint16, got {array.dtype}")
    wide = [array for array in arrays if array.dtype == np.uint16]
    brightest = max((int(array.max(initial=0)) for array in wide), default=0)
    shift = max(brightest.bit_length() - 8, 0)
    return tuple(array if array.dtype == np.uint8 else (array >> shift).astype(np.uint8) for array in arrays)


def _is_grey_content(rgb: np.ndarray) -> bool:
    """True when all three channels are identical (a grey picture saved as RGB)."""
    return bool(np.array_equal(rgb[..., 0], rgb[..., 1]) and np.array_equal(rgb[..., 1], rgb[..., 2]))


def check_image_path(path: PathLike) -> None:
    """Raise :class:`OutputError` unless ``path`` ends in an image extension :func:`write_image`
    writes (commands check this before any work, so that no output is written without the next)."""
    suffix = Path(path).suffix.lower()
    if suffix not in _IMAGE_SUFFIXES:
        raise OutputError(f"{path}: unknown image extension {suffix!r} (use .png, .jpg, ...)")


def write_image(path: PathLike, image: np.ndarray) -> Path:
    """Write an 8- or 16-bit grey ``(H, W)`` or RGB ``(H, W, 3)`` image, format by extension."""
    p = Path(path)
    check_image_path(p)
    suffix = p.suffix.lower()
    array = np.asarray(image)
    if array.dtype not in (np.uint8, np.uint16):
        raise InvalidInputError(f"image to write must be uint8 or uint16, got {array.dtype}")
    if array.ndim == 3 and array.shape[2] == 3:
        array = cv2.cvtColor(array, cv2.COLOR_RGB2BGR)
    elif array.ndim != 2:
        raise InvalidInputError(f"image to write must be (H, W) or (H, W, 3), got shape {array.shape}")
    ok, encoded = cv2.imencode(suffix, array)
    if not ok:
        raise OutputError(f"OpenCV could not encode {p} as {suffix}")
    return write_bytes_atomic(p, encoded.tobytes())


# --- disparity -------------------------------------------------------------------------------

def write_pfm(path: PathLike, array: np.ndarray) -> Path:
    """Write a float map as PFM: little-endian, rows bottom to top, NaN stored as ``+inf``."""
    a = check_float_map(array, "map").astype(np.float32, copy=False)
    out = np.where(np.isnan(a), np.float32(np.inf), a).astype("<f4")
    h, w = out.shape
    header = f"Pf\n{w} {h}\n-1.0\n".encode("ascii")
    return write_bytes_atomic(path, header + np.flipud(out).tobytes())


_PFM_HEADER = re.compile(rb"^(PF|Pf)\s+(\d+)\s+(\d+)\s+([-+0-9.eE]+)\s")


def read_pfm(path: PathLike) -> np.ndarray:
    """Read a grey PFM as ``float32 (H, W)`` with non-finite values (invalid) as NaN.

    A colour PFM (``PF``) is rejected: disparity and depth are single-channel.
    """
    data = _read_file_bytes(path, "PFM file")
    match = _PFM_HEADER.match(data[:256])
    if match is None:
        raise InputFileError(f"{path} is not a PFM file (bad header)")
    kind, w, h = match.group(1), int(match.group(2)), int(match.group(3))
    try:
        scale = float(match.group(4))
    except ValueError as exc:  # the pattern admits "-1-0" or "-": not numbers
        raise InputFileError(f"{path}: bad PFM scale {match.group(4).decode('ascii')!r}") from exc
    if kind == b"PF":
        raise InputFileError(f"{path} is a 3-channel PFM; a single-channel map is expected")
    if w <= 0 or h <= 0 or scale == 0:
        raise InputFileError(f"{path}: bad PFM header (width {w}, height {h}, scale {scale})")
    payload = data[match.end():]
    expected = w * h * 4
    if len(payload) < expected:
        raise InputFileError(f"{path} is truncated: {len(payload)} bytes of pixels, {expected} expected")
    dtype = "<f4" if scale < 0 else ">f4"
    a = np.frombuffer(payload[:expected], dtype=dtype).reshape(h, w)
    a = np.flipud(a).astype(np.float32)
    a[~np.isfinite(a)] = np.nan
    return a


def write_kitti_disparity(path: PathLike, disparity: np.ndarray) -> Path:
    """Write disparity as a KITTI 16-bit PNG (``round(d * 256)``, 0 = invalid).

    Disparities ``<= 0`` cannot be represented (0 means invalid) and are written as invalid;
    values above :data:`KITTI_MAX_DISPARITY` raise :class:`InvalidInputError`.
    """
    d = check_float_map(disparity, "disparity").astype(np.float32, copy=False)
    valid = np.isfinite(d) & (d > 0)
    if valid.any() and float(d[valid].max()) > KITTI_MAX_DISPARITY:
        raise InvalidInputError(
            f"disparity up to {float(d[valid].max()):.1f} px does not fit a KITTI PNG "
            f"(max {KITTI_MAX_DISPARITY:.1f}); write .pfm or .npy instead")
    encoded = np.zeros(d.shape, dtype=np.uint16)
    encoded[valid] = np.clip(np.rint(d[valid] * KITTI_DISPARITY_SCALE), 1, 65535).astype(np.uint16)
    return write_image(path, encoded)


def read_kitti_disparity(path: PathLike) -> np.ndarray:
    """Read a KITTI 16-bit disparity PNG as ``float32`` pixels with NaN where the value is 0."""
    raw = read_image(path, mode="any")
    if raw.ndim != 2 or raw.dtype != np.uint16:
        raise InputFileError(f"{path} is not a KITTI disparity PNG (expected 16-bit grey, "
                             f"got {raw.dtype} with shape {raw.shape})")
    d = raw.astype(np.float32) / KITTI_DISPARITY_SCALE
    d[raw == 0] = np.nan
    return d


def write_npy(path: PathLike, array: np.ndarray) -> Path:
    """Write a float map as ``.npy`` float32 (NaN = invalid)."""
    a = check_float_map(array, "map").astype(np.float32, copy=False)
    buffer = io.BytesIO()
    np.save(buffer, a, allow_pickle=False)
    return write_bytes_atomic(path, buffer.getvalue())


def read_npy(path: PathLike) -> np.ndarray:
    """Read a 2-D float ``.npy`` map as ``float32``; non-finite values become NaN."""
    data = _read_file_bytes(path, ".npy file")
    try:
        a = np.load(io.BytesIO(data), allow_pickle=False)
    except (ValueError, EOFError, OSError, SyntaxError, tokenize.TokenError) as exc:  # the header is parsed as Python
        raise InputFileError(f"{path} is not a valid .npy file: {exc}") from exc
    if a.ndim != 2 or not np.issubdtype(a.dtype, np.floating):
        raise InputFileError(f"{path}: expected a 2-D float array, got {a.dtype} {a.shape}")
    a = a.astype(np.float32)
    a[~np.isfinite(a)] = np.nan
    return a


def check_disparity_path(path: PathLike) -> None:
    """Raise :class:`OutputError` unless ``path`` ends in ``.npy``, ``.pfm`` or ``.png``."""
    suffix = Path(path).suffix.lower()
    if suffix not in (".npy", ".pfm", ".png"):
        raise OutputError(f"{path}: disparity can be written as .npy, .pfm or .png, not {suffix!r}")


def write_disparity(path: PathLike, disparity: np.ndarray) -> Path:
    """Write a disparity map, the format chosen by extension: ``.npy``, ``.pfm`` or ``.png`` (KITTI)."""
    check_disparity_path(path)
    writers = {".npy": write_npy, ".pfm": write_pfm, ".png": write_kitti_disparity}
    return writers[Path(path).suffix.lower()](path, disparity)


def read_disparity(path: PathLike) -> np.ndarray:
    """Read a disparity map written by :func:`write_disparity` (``.npy``, ``.pfm``, KITTI ``.png``)."""
    suffix = Path(path).suffix.lower()
    readers = {".npy": read_npy, ".pfm": read_pfm, ".png": read_kitti_disparity}
    if suffix not in readers:
        raise InputFileError(f"{path}: disparity can be read from .npy, .pfm or .png, not {suffix!r}")
    return readers[suffix](path)


# --- depth and labels ------------------------------------------------------------------------

def write_depth(path: PathLike, depth_m: np.ndarray) -> Path:
    """Write depth in metres: ``.npy`` float32 metres, ``.pfm``, or ``.png`` 16-bit millimetres.

    In the PNG, 0 means unknown (NaN) and depths beyond 65.535 m are clipped to 65535 mm.
    """
    suffix = Path(path).suffix.lower()
    d = check_float_map(depth_m, "depth").astype(np.float32, copy=False)
    if suffix == ".npy":
        return write_npy(path, d)
    if suffix == ".pfm":
        return write_pfm(path, d)
    if suffix == ".png":
        valid = np.isfinite(d) & (d > 0)
        mm = np.zeros(d.shape, dtype=np.uint16)
        mm[valid] = np.clip(np.rint(d[valid] * 1000.0), 1, 65535).astype(np.uint16)
        return write_image(path, mm)
    raise OutputError(f"{path}: depth can be written as .npy, .pfm or .png, not {suffix!r}")


def read_depth(path: PathLike) -> np.ndarray:
    """Read a depth map written by :func:`write_depth`, in metres with NaN where unknown."""
    suffix = Path(path).suffix.lower()
    if suffix == ".npy":
        return read_npy(path)
    if suffix == ".pfm":
        return read_pfm(path)
    if suffix == ".png":
        raw = read_image(path, mode="any")
        if raw.ndim != 2 or raw.dtype != np.uint16:
            raise InputFileError(f"{path} is not a 16-bit millimetre depth PNG")
        d = raw.astype(np.float32) / 1000.0
        d[raw == 0] = np.nan
        return d
    raise InputFileError(f"{path}: depth can be read from .npy, .pfm or .png, not {suffix!r}")


def write_labels(path: PathLike, labels: np.ndarray) -> Path:
    """Write a ``uint8 (H, W)`` label image as a lossless PNG."""
    a = np.asarray(labels)
    if a.ndim != 2 or a.dtype != np.uint8:
        raise InvalidInputError(f"labels must be uint8 (H, W), got {a.dtype} {a.shape}")
    check_labels_path(path)
    return write_image(path, a)


def check_labels_path(path: PathLike) -> None:
    """Raise :class:`OutputError` unless ``path`` ends in ``.png`` (labels must be lossless)."""
    if Path(path).suffix.lower() != ".png":
        raise OutputError(f"{path}: labels are written as .png (lossless)")


def read_labels(path: PathLike) -> np.ndarray:
    """Read a label PNG as ``uint8 (H, W)``."""
    a = read_image(path, mode="any")
    if a.ndim != 2 or a.dtype != np.uint8:
        raise InputFileError(f"{path} is not an 8-bit single-channel label image")
    return a


__all__ = [
    "KITTI_DISPARITY_SCALE", "KITTI_MAX_DISPARITY",
    "read_image", "write_image", "read_pfm", "write_pfm", "read_kitti_disparity",
    "write_kitti_disparity", "read_npy", "write_npy", "read_disparity", "write_disparity",
    "read_depth", "write_depth", "read_labels", "write_labels", "to_uint8",
]
