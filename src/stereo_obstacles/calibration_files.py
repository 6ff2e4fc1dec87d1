"""Reading a rectified stereo calibration from the file formats people have.

Supported, detected from the content:

* the project's own JSON (:func:`stereo_obstacles.calibration.write_calibration_json`);
* Middlebury 2014 ``calib.txt`` (``cam0=[f 0 cx; 0 f cy; 0 0 1]``, ``doffs``, ``baseline`` in mm);
* KITTI calibration text (``P_rect_02``/``P_rect_03`` or ``P2``/``P3`` 3x4 rectified projection
  matrices; the stereo baseline is ``(P2[0,3] - P3[0,3]) / f``, already in metres);
* OpenCV ``FileStorage`` YAML/XML as written after ``stereoCalibrate``/``stereoRectify``
  (rectified ``P1``, ``P2``, optional ``imageSize``); the length unit of ``T`` is the unit of
  the chessboard square size, which the file does not record, so it is passed as
  ``length_unit``;
* an OpenCV 4x4 reprojection matrix ``Q`` stored as 16 numbers in a text file.
"""

from __future__ import annotations

import logging
import math
import os
import re
from pathlib import Path

import numpy as np

from stereo_obstacles.calibration import StereoCalibration, read_calibration_json
from stereo_obstacles.errors import CalibrationError, InputFileError

LENGTH_UNITS_M = {"m": 1.0, "cm": 0.01, "mm": 0.001}
"""Metres per unit for the ``length_unit`` argument."""

IMPLAUSIBLE_BASELINE_M = 5.0
"""A baseline above this (metres) in a unit-less file is taken as a unit mistake, not a rig."""

logger = logging.getLogger(__name__)

_NUMBER = re.compile(r"^[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$")


def read_calibration(path: str | os.PathLike[str], *, length_unit: str | None = None) -> StereoCalibration:
    """Read a rectified stereo calibration, detecting the file format from its content.

    Parameters
    ----------
    path
        A calibration file in one of the formats listed in the module docstring.
    length_unit
        ``"m"``, ``"cm"`` or ``"mm"``: the unit of the translation in an OpenCV file (which does
        not record it) or of a ``Q`` matrix. Default: metres, and a baseline over
        :data:`IMPLAUSIBLE_BASELINE_M` is refused with a hint to pass the unit. Not used, with
        a warning, for the formats that state their unit (JSON, Middlebury, KITTI).

    Raises
    ------
    InputFileError
        The file is missing or unreadable.
    CalibrationError
        The content is not a recognised calibration or holds impossible values.
    """
    if length_unit is not None and length_unit not in LENGTH_UNITS_M:
        raise CalibrationError(f"length_unit must be one of {sorted(LENGTH_UNITS_M)}, got {length_unit!r}")
    p = Path(path)
    if not p.is_file():
        raise InputFileError(f"calibration file {p} does not exist" if not p.exists()
                             else f"calibration file {p} is not a regular file")
    try:
        text = p.read_text(encoding="utf-8", errors="strict")
    except (OSError, UnicodeDecodeError) as exc:
        raise CalibrationError(f"calibration file {p} is not a text file: {exc}") from exc
    stripped = text.lstrip()
    if stripped.startswith("{"):
        calibration = read_calibration_json(p)
        warn_unit_not_used(length_unit, p, "this tool's JSON calibration, in metres")
        return calibration
    if stripped.startswith("%YAML") or stripped.startswith("<?xml") or "opencv-matrix" in text \
            or "<opencv_storage>" in text:
        return _read_opencv_storage(p, length_unit)
    if re.search(r"^\s*cam0\s*=", text, flags=re.MULTILINE):
        calibration = _parse_middlebury(text, str(p))
        warn_unit_not_used(length_unit, p, "a Middlebury calib.txt, in millimetres")
        return calibration
    fields = _keyed_numbers(text)
    if ("P_rect_02" in fields and "P_rect_03" in fields) or ("P2" in fields and "P3" in fields):
        calibration = _parse_kitti(fields, str(p))
        warn_unit_not_used(length_unit, p, "a KITTI calibration, in metres")
        return calibration
    for left_key, right_key in (("P_rect_02", "P_rect_03"), ("P2", "P3")):
        if (left_key in fields) != (right_key in fields):
            present, missing = (left_key, right_key) if left_key in fields else (right_key, left_key)
            raise CalibrationError(f"{p}: a KITTI calibration with {present} but without {missing}; both colour "
                                   f"cameras' projections are needed")
    numbers = [t for t in text.split() if _NUMBER.match(t)]
    if len(numbers) == 16 and len(numbers) == len(text.split()):
        return _parse_q_matrix(np.array(numbers, dtype=float).reshape(4, 4), str(p), length_unit)
    raise CalibrationError(
        f"{p} is not a calibration format this tool reads (project JSON, Middlebury calib.txt, "
        f"KITTI P_rect, OpenCV YAML/XML with P1/P2, or a 4x4 Q matrix)")


def warn_unit_not_used(length_unit: str | None, path: Path, format_and_unit: str) -> None:
    """Log a warning when a ``length_unit`` was given for a file whose format states its own
    (``format_and_unit``, e.g. ``"a Middlebury calib.txt, in millimetres"``): it is not used."""
    if length_unit is not None:
        logger.warning("the length unit %r (--calib-unit) is not used: %s is %s", length_unit, path, format_and_unit)


def unit_scale(length_unit: str | None, baseline_in_file: float, source: str) -> float:
    """Metres per unit of a file that does not state its length unit (``length_unit``, default
    metres); a baseline above :data:`IMPLAUSIBLE_BASELINE_M` in the file's unit, with no unit given,
    is refused with a hint to give it (``source`` names the file in the message)."""
    scale = LENGTH_UNITS_M[length_unit or "m"]
    if length_unit is None and abs(baseline_in_file) > IMPLAUSIBLE_BASELINE_M:
        raise CalibrationError(
            f"{source}: the baseline is {abs(baseline_in_file):.4g} in the file's length unit, "
            f"implausible in metres; the file does not say its unit, so give it "
            f"(--calib-unit mm or cm, or length_unit=...)")
    return scale


def _parse_middlebury(text: str, source: str) -> StereoCalibration:
    values: dict[str, str] = {}
    for line in text.splitlines():
        if "=" in line:
            key, _, value = line.partition("=")
            values[key.strip()] = value.strip()
    try:
        cam0 = _matlab_matrix(values["cam0"])
        cam1 = _matlab_matrix(values["cam1"]) if "cam1" in values else None
        baseline_mm = float(values["baseline"])
        if "doffs" not in values and cam1 is None:
            raise CalibrationError(f"{source}: Middlebury calib.txt lacks 'doffs' and 'cam1' (one gives the "
                                   f"principal points' offset)")
        doffs = float(values["doffs"]) if "doffs" in values else float(cam1[0, 2] - cam0[0, 2])
        width = int(values["width"]) if "width" in values else None
        height = int(values["height"]) if "height" in values else None
    except KeyError as exc:
        raise CalibrationError(f"{source}: Middlebury calib.txt lacks {exc.args[0]!r}") from exc
    except ValueError as exc:
        raise CalibrationError(f"{source}: Middlebury calib.txt does not parse: {exc}") from exc
    return StereoCalibration(focal_px=float(cam0[0, 0]), cx_px=float(cam0[0, 2]), cy_px=float(cam0[1, 2]),
                             baseline_m=baseline_mm / 1000.0, width_px=width, height_px=height,
                             doffs_px=doffs)


def _matlab_matrix(text: str) -> np.ndarray:
    rows = [r.split() for r in text.strip().strip("[]").split(";")]
    matrix = np.array(rows, dtype=float)
    if matrix.shape != (3, 3):
        raise ValueError(f"camera matrix must be 3x3, got {matrix.shape}")
    return matrix


def _keyed_numbers(text: str) -> dict[str, list[float | str] | None]:
    """Map each ``key:`` of a KITTI-style file to the tokens that follow it (over line breaks):
    numbers as floats, anything else (``nan``, ``1.2x``) as its text, for :func:`_projection` to
    name. A key given twice maps to None: which of the two is meant cannot be told."""
    fields: dict[str, list[float | str] | None] = {}
    key = None
    for token in text.split():
        if token.endswith(":"):
            key = token[:-1]
            fields[key] = None if key in fields else []
        elif key is not None and fields[key] is not None:
            fields[key].append(float(token) if _NUMBER.match(token) else token)
    return fields


def _projection(fields: dict[str, list[float | str] | None], names: tuple[str, ...], source: str) -> np.ndarray:
    for name in names:
        if name in fields:
            values = fields[name]
            if values is None:
                raise CalibrationError(f"{source}: {name} is given twice")
            words = [v for v in values if isinstance(v, str)]
            if words:
                raise CalibrationError(f"{source}: {name} holds {words[0]!r}, which is not a finite number")
            if len(values) != 12:
                raise CalibrationError(f"{source}: {name} must have 12 numbers, has {len(values)}")
            return np.array(values).reshape(3, 4)
    raise CalibrationError(f"{source}: no {' or '.join(names)}")


def _check_rectified(left: np.ndarray, right: np.ndarray, source: str, names: tuple[str, str]) -> None:
    """The two 3x4 projections of a rectified pair share the focal lengths and the principal
    point's row (only the columns may differ, by ``doffs``); raise :class:`CalibrationError` if not."""
    for (row, col), what in (((0, 0), "focal length fx"), ((1, 1), "focal length fy"), ((1, 2), "principal row cy")):
        a, b = float(left[row, col]), float(right[row, col])
        if abs(a - b) > 1e-6 * max(abs(a), abs(b), 1.0):
            raise CalibrationError(f"{source}: {names[0]} and {names[1]} differ in their {what} ({a:g} and {b:g}); "
                                   f"not a rectified pair")


def _parse_kitti(fields: dict[str, list[float | str] | None], source: str) -> StereoCalibration:
    left = _projection(fields, ("P_rect_02", "P2"), source)
    right = _projection(fields, ("P_rect_03", "P3"), source)
    focal = float(left[0, 0])
    if focal <= 0:
        raise CalibrationError(f"{source}: focal length {focal} must be > 0")
    _check_rectified(left, right, source, ("P_rect_02", "P_rect_03") if "P_rect_02" in fields else ("P2", "P3"))
    baseline = float(left[0, 3] - right[0, 3]) / focal
    size = fields.get("S_rect_02") or []
    width, height = (int(size[0]), int(size[1])) if len(size) == 2 and all(isinstance(v, float) for v in size) \
        else (None, None)
    return StereoCalibration(focal_px=focal, cx_px=float(left[0, 2]), cy_px=float(left[1, 2]),
                             baseline_m=baseline, width_px=width, height_px=height,
                             doffs_px=float(right[0, 2] - left[0, 2]))


def open_opencv_storage(path: str | os.PathLike[str]):
    """Open an OpenCV ``FileStorage`` YAML/XML file for reading.

    Returns
    -------
    cv2.FileStorage
        Open or not (check ``isOpened()``); the caller releases it.

    Raises
    ------
    CalibrationError
        OpenCV's parser rejects the file (it reports some parse errors as ``SystemError``
        wrapping a ``cv2.error``).
    """
    import cv2

    try:
        return cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    except (cv2.error, SystemError) as exc:
        cause = exc if isinstance(exc, cv2.error) else exc.__cause__
        reason = " ".join((cause.msg if isinstance(cause, cv2.error) else str(exc)).split())
        where = re.search(r"in function '(.*)'", reason)  # OpenCV puts "file(line): problem" there
        reason = where.group(1) if where else reason
        raise CalibrationError(f"{path}: OpenCV cannot parse this file: {reason}") from exc


def _is_matrix_node(node) -> bool:
    """Whether an OpenCV ``FileStorage`` node is an ``opencv-matrix`` or ``opencv-nd-matrix``
    (a map with ``dt`` and ``data``), not any other map, sequence or number."""
    return node.isMap() and not node.getNode("dt").empty() and not node.getNode("data").empty()


def opencv_image_size(node, source: str) -> tuple[int, int] | None:
    """The ``(width, height)`` of an OpenCV ``FileStorage`` ``imageSize`` node, ``None`` when the
    file has none: a sequence ``[w, h]`` (as OpenCV's ``stereo_calib.cpp`` writes it) or a matrix
    (``!!opencv-matrix``, as ``calibrate`` writes it, or ``!!opencv-nd-matrix``, as Python's
    ``FileStorage.write`` of a 1-D array writes it).

    Raises
    ------
    CalibrationError
        Anything else than two positive whole numbers (``source`` names the file).
    """
    if node.empty():
        return None
    values: list = []
    if _is_matrix_node(node):
        matrix = node.mat()
        values = [] if matrix is None else np.asarray(matrix, dtype=np.float64).ravel().tolist()
    elif node.isSeq():
        items = [node.at(i) for i in range(node.size())]
        values = [item.real() if item.isReal() or item.isInt() else None for item in items]
    if len(values) != 2 or not all(v is not None and math.isfinite(v) and v >= 1 and v == int(v) for v in values):
        shown = values if values else "not a list or matrix of numbers"
        raise CalibrationError(f"{source}: imageSize must hold 2 positive whole numbers (width, height), got {shown}")
    return int(values[0]), int(values[1])


def _opencv_matrix(node, name: str, source: str) -> np.ndarray | None:
    """The matrix of an OpenCV ``FileStorage`` node, ``None`` when the file has none; a node that
    is not a readable matrix (``P1: 5``, 3 values for 3 x 4) is refused naming it, not with
    OpenCV's assertion text."""
    import cv2

    if node.empty():
        return None
    if _is_matrix_node(node):
        try:
            return node.mat()
        except cv2.error:                        # rows x cols not the count of data, a dt OpenCV does not know
            pass
    raise CalibrationError(f"{source}: {name} must be a matrix (!!opencv-matrix with rows, cols, dt and data, "
                           f"rows x cols values)")


def _read_opencv_storage(path: Path, length_unit: str | None) -> StereoCalibration:
    import cv2

    source = str(path)
    storage = open_opencv_storage(path)
    try:
        if not storage.isOpened():
            raise CalibrationError(f"{source}: OpenCV cannot open this file as YAML/XML")
        left, right = (_opencv_matrix(storage.getNode(name), name, source) for name in ("P1", "P2"))
        raw_cameras = not storage.getNode("cameraMatrix1").empty()
        size = opencv_image_size(storage.getNode("imageSize"), source)
    except cv2.error as exc:  # a node of the wrong kind (a list where a map is expected, a bad matrix)
        raise CalibrationError(f"{source}: malformed OpenCV calibration: {' '.join(exc.msg.split())}") from exc
    finally:
        storage.release()
    if left is None or right is None:
        # an image list (OpenCV's stereo_calib.xml) was told to "rectify with stereoRectify first"
        raise CalibrationError(
            f"{source} has no rectified projection matrices P1 and P2: "
            + ("it describes the raw cameras (cameraMatrix1/2); give it with --calib to a command that rectifies "
               "the pair first (rectify, detect, video, batch)" if raw_cameras
               else "not a stereo calibration (this tool reads P1/P2, or cameraMatrix1/2, distCoeffs1/2, R and T)"))
    if left.shape != (3, 4) or right.shape != (3, 4):
        raise CalibrationError(f"{source}: P1 and P2 must be 3x4, got {left.shape} and {right.shape}")
    focal = float(left[0, 0])
    if focal <= 0:
        raise CalibrationError(f"{source}: focal length {focal} must be > 0")
    _check_rectified(left, right, source, ("P1", "P2"))
    if abs(right[1, 3]) > abs(right[0, 3]):
        raise CalibrationError(f"{source} describes a vertical stereo rig; only horizontal rigs are supported")
    baseline_in_file = -float(right[0, 3]) / focal
    scale = unit_scale(length_unit, baseline_in_file, source)
    width, height = size if size is not None else (None, None)
    return StereoCalibration(focal_px=focal, cx_px=float(left[0, 2]), cy_px=float(left[1, 2]),
                             baseline_m=abs(baseline_in_file) * scale, width_px=width, height_px=height,
                             doffs_px=float(right[0, 2] - left[0, 2]))


def _parse_q_matrix(q: np.ndarray, source: str, length_unit: str | None) -> StereoCalibration:
    """OpenCV's Q: [[1,0,0,-cx],[0,1,0,-cy],[0,0,0,f],[0,0,-1/Tx,(cx-cx')/Tx]]."""
    focal, inverse_baseline = float(q[2, 3]), float(q[3, 2])
    if focal <= 0 or inverse_baseline == 0:
        raise CalibrationError(f"{source}: not a valid Q matrix (f = {focal}, 1/B = {inverse_baseline})")
    baseline_in_file = 1.0 / abs(inverse_baseline)
    scale = unit_scale(length_unit, baseline_in_file, source)
    # Q[3,3] = (cx - cx') / Tx and Q[3,2] = -1 / Tx, so cx' - cx = Q[3,3] / Q[3,2].
    doffs = float(q[3, 3] / q[3, 2])
    return StereoCalibration(focal_px=focal, cx_px=-float(q[0, 3]), cy_px=-float(q[1, 3]),
                             baseline_m=baseline_in_file * scale, doffs_px=doffs)
