"""The full calibration of an unrectified stereo pair, and its JSON and OpenCV YAML files.

A :class:`CameraPairCalibration` holds what ``cv2.stereoCalibrate`` finds: each camera's
matrix and lens distortion, the rotation ``R`` and translation ``T`` from the left to the
right camera (a left-camera point ``X`` is ``R @ X + T`` in the right camera, OpenCV's
convention) and the image size. The rectification it implies is in
:mod:`stereo_obstacles.rectification`; :class:`~stereo_obstacles.calibration.StereoCalibration`
stays the type of a *rectified* pair.

Files:

* the project's JSON (``format`` ``"stereo-obstacles/camera-pair-calibration"``, version 1),
  translation in metres;
* OpenCV ``FileStorage`` YAML with ``cameraMatrix1/2``, ``distCoeffs1/2``, ``R``, ``T``,
  ``imageSize`` (the names of OpenCV's ``stereo_calib.cpp`` sample), plus the rectification
  ``R1``, ``R2``, ``P1``, ``P2``, ``Q`` when written by :func:`write_opencv_yaml`, so other
  tools can reuse the file. ``T`` is written in metres.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from stereo_obstacles.atomic import atomic_path, write_text_atomic
from stereo_obstacles.errors import CalibrationError, InvalidInputError, OutputError
from stereo_obstacles.json_documents import check_document, load_json_file

CAMERA_PAIR_FORMAT = "stereo-obstacles/camera-pair-calibration"
CAMERA_PAIR_VERSION = 1

DISTORTION_LENGTHS = (4, 5, 8, 12, 14)
"""Numbers of distortion coefficients OpenCV accepts."""


def _matrix(name: str, value, shape: tuple[int, ...]) -> np.ndarray:
    try:
        array = np.array(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise CalibrationError(f"calibration {name} must be numbers, got {value!r}") from exc
    if array.size == math.prod(shape):
        array = array.reshape(shape)
    if array.shape != shape:
        raise CalibrationError(f"calibration {name} must have shape {shape}, got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise CalibrationError(f"calibration {name} must be finite, got {array.tolist()}")
    array.setflags(write=False)
    return array


def _distortion(name: str, value) -> np.ndarray:
    array = np.array(value if value is not None else [], dtype=np.float64).ravel()
    if array.size == 0:
        array = np.zeros(5)
    if array.size not in DISTORTION_LENGTHS:
        raise CalibrationError(f"calibration {name} must have one of {DISTORTION_LENGTHS} coefficients, "
                               f"got {array.size}")
    return _matrix(name, array, (array.size,))


@dataclass(frozen=True, eq=False)
class CameraPairCalibration:
    """Calibration of a stereo pair before rectification (OpenCV conventions).

    Attributes
    ----------
    camera_matrix_left, camera_matrix_right : ndarray, shape (3, 3)
        Camera matrices ``[[fx, s, cx], [0, fy, cy], [0, 0, 1]]``, pixels.
    distortion_left, distortion_right : ndarray, shape (N,)
        OpenCV distortion coefficients ``(k1, k2, p1, p2[, k3[, k4, k5, k6[, ...]]])``,
        ``N`` in :data:`DISTORTION_LENGTHS`; zeros for an ideal lens.
    rotation : ndarray, shape (3, 3)
        ``R``: a left-camera point ``X`` is ``R @ X + T`` in the right camera.
    translation_m : ndarray, shape (3,)
        ``T`` in metres; for a side-by-side rig ``T[0]`` is about minus the baseline.
    width_px, height_px : int
        Image size the calibration belongs to.
    rms_px : float or None
        RMS reprojection error of the calibration, pixels, when known.
    """

    camera_matrix_left: np.ndarray
    distortion_left: np.ndarray
    camera_matrix_right: np.ndarray
    distortion_right: np.ndarray
    rotation: np.ndarray
    translation_m: np.ndarray
    width_px: int
    height_px: int
    rms_px: float | None = None

    def __post_init__(self) -> None:
        for side in ("left", "right"):
            k = _matrix(f"camera_matrix_{side}", getattr(self, f"camera_matrix_{side}"), (3, 3))
            if k[0, 0] <= 0 or k[1, 1] <= 0 or not np.allclose(k[2], (0.0, 0.0, 1.0)) or k[1, 0] != 0:
                raise CalibrationError(f"calibration camera_matrix_{side} is not a camera matrix "
                                       f"(positive focal lengths, last row 0 0 1): {k.tolist()}")
            object.__setattr__(self, f"camera_matrix_{side}", k)
            object.__setattr__(self, f"distortion_{side}",
                               _distortion(f"distortion_{side}", getattr(self, f"distortion_{side}")))
        r = _matrix("rotation", self.rotation, (3, 3))
        if not np.allclose(r @ r.T, np.eye(3), atol=1e-6) or np.linalg.det(r) < 0:
            raise CalibrationError(f"calibration rotation is not a rotation matrix: {r.tolist()}")
        object.__setattr__(self, "rotation", r)
        t = _matrix("translation_m", self.translation_m, (3,))
        baseline = float(np.linalg.norm(t))
        if not 0 < baseline <= 100:
            raise CalibrationError(f"calibration baseline |T| = {baseline:.4g} m is not in (0, 100] metres "
                                   f"(millimetres given as metres?)")
        object.__setattr__(self, "translation_m", t)
        for name in ("width_px", "height_px"):
            value = getattr(self, name)
            if not isinstance(value, (int, np.integer)) or isinstance(value, bool) or value <= 0:
                raise CalibrationError(f"calibration {name} must be a positive integer, got {value!r}")
            object.__setattr__(self, name, int(value))
        if self.rms_px is not None and not (math.isfinite(self.rms_px) and self.rms_px >= 0):
            raise CalibrationError(f"calibration rms_px must be a finite number >= 0, got {self.rms_px!r}")

    @property
    def baseline_m(self) -> float:
        """Distance between the optical centres, metres."""
        return float(np.linalg.norm(self.translation_m))

    @property
    def image_size(self) -> tuple[int, int]:
        """``(width, height)`` in pixels, as OpenCV functions take it."""
        return self.width_px, self.height_px

    def check_image_size(self, width_px: int, height_px: int) -> None:
        """Raise :class:`CalibrationError` when the images are not the calibrated size."""
        if (width_px, height_px) != self.image_size:
            raise CalibrationError(f"calibration is for {self.width_px}x{self.height_px} images, "
                                   f"the images are {width_px}x{height_px}")

    def to_dict(self) -> dict:
        """JSON-ready mapping with the format name and version."""
        return {"format": CAMERA_PAIR_FORMAT, "version": CAMERA_PAIR_VERSION,
                "camera_matrix_left": self.camera_matrix_left.tolist(),
                "distortion_left": self.distortion_left.tolist(),
                "camera_matrix_right": self.camera_matrix_right.tolist(),
                "distortion_right": self.distortion_right.tolist(),
                "rotation": self.rotation.tolist(), "translation_m": self.translation_m.tolist(),
                "width_px": self.width_px, "height_px": self.height_px, "rms_px": self.rms_px}

    @classmethod
    def from_dict(cls, data: dict, *, source: str = "calibration") -> CameraPairCalibration:
        """Build from :meth:`to_dict` output; raise :class:`CalibrationError` on bad content."""
        check_document(data, format_name=CAMERA_PAIR_FORMAT, version=CAMERA_PAIR_VERSION, source=source,
                       error=CalibrationError)
        fields = ("camera_matrix_left", "distortion_left", "camera_matrix_right", "distortion_right",
                  "rotation", "translation_m", "width_px", "height_px")
        missing = [f for f in fields if f not in data]
        if missing:
            raise CalibrationError(f"{source} lacks {', '.join(missing)}")
        return cls(**{f: data[f] for f in fields}, rms_px=data.get("rms_px"))


def is_camera_pair_json(data: object) -> bool:
    """True when a parsed JSON document claims to be a :class:`CameraPairCalibration`."""
    return isinstance(data, dict) and data.get("format") == CAMERA_PAIR_FORMAT


def write_camera_pair_json(path: str | os.PathLike[str], calibration: CameraPairCalibration) -> None:
    """Write ``calibration`` as the project's JSON (atomically)."""
    write_text_atomic(path, json.dumps(calibration.to_dict(), indent=2) + "\n")


def read_camera_pair_json(path: str | os.PathLike[str]) -> CameraPairCalibration:
    """Read the project's JSON camera-pair calibration."""
    data = load_json_file(path, what="calibration", error=CalibrationError)
    return CameraPairCalibration.from_dict(data, source=str(path))


OPENCV_FILE_MARK = "written by stereo-obstacles"
"""The comment at the top of the OpenCV files :func:`write_opencv_yaml` writes (OpenCV skips it):
how a later run knows such a file for its own (:func:`is_marked_opencv_file`)."""


def is_marked_opencv_file(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` begins like a file :func:`write_opencv_yaml` wrote (its comment among the
    first lines)."""
    try:
        with open(path, "rb") as file:
            head = file.read(256)
    except OSError:
        return False
    return OPENCV_FILE_MARK.encode() in head


def write_opencv_yaml(path: str | os.PathLike[str], calibration: CameraPairCalibration,
                      rectified: dict[str, np.ndarray] | None = None) -> None:
    """Write ``calibration`` as OpenCV ``FileStorage`` YAML (atomically).

    Parameters
    ----------
    path
        Output file; its name must end in ``.yml``, ``.yaml`` or ``.xml`` (OpenCV picks the
        syntax from it).
    calibration
        What to write; ``T`` goes out in metres.
    rectified
        Extra matrices to store beside it by name, e.g. ``R1``, ``R2``, ``P1``, ``P2``, ``Q``
        (:meth:`stereo_obstacles.rectification.Rectification.opencv_matrices` gives them).
    """
    import cv2

    if rectified is not None and not isinstance(rectified, dict):
        raise InvalidInputError(f"rectified: expected a dict of named matrices (Rectification.opencv_matrices()), "
                                f"got {type(rectified).__name__}")
    suffix = Path(path).suffix.lower()
    if suffix not in (".yml", ".yaml", ".xml"):
        raise OutputError(f"OpenCV calibration file {path} must end in .yml, .yaml or .xml, not {suffix!r}")
    with atomic_path(path) as temporary:  # the temporary name ends in the real suffix, as OpenCV needs
        storage = cv2.FileStorage(str(temporary), cv2.FILE_STORAGE_WRITE)
        try:
            storage.writeComment(OPENCV_FILE_MARK)
            storage.write("imageSize", np.array(calibration.image_size, dtype=np.int32).reshape(1, 2))
            storage.write("cameraMatrix1", calibration.camera_matrix_left)
            storage.write("distCoeffs1", calibration.distortion_left.reshape(1, -1))
            storage.write("cameraMatrix2", calibration.camera_matrix_right)
            storage.write("distCoeffs2", calibration.distortion_right.reshape(1, -1))
            storage.write("R", calibration.rotation)
            storage.write("T", calibration.translation_m.reshape(3, 1))
            if calibration.rms_px is not None:
                storage.write("rms", float(calibration.rms_px))
            for name, matrix in (rectified or {}).items():
                storage.write(name, np.asarray(matrix, dtype=np.float64))
        finally:
            storage.release()


def camera_pair_from_opencv_storage(storage, source: str, length_unit: str | None) -> CameraPairCalibration | None:
    """The calibration in an open ``cv2.FileStorage``, or ``None`` when it lacks the matrices.

    ``length_unit`` (``"m"``, ``"cm"``, ``"mm"``) is the unit of the file's translation; ``None``
    takes metres and refuses a baseline above ``IMPLAUSIBLE_BASELINE_M`` with a hint to give it.
    """
    from stereo_obstacles.calibration_files import opencv_image_size, unit_scale

    names = ("cameraMatrix1", "cameraMatrix2", "R", "T")
    nodes = {name: storage.getNode(name) for name in (*names, "distCoeffs1", "distCoeffs2")}
    if any(nodes[name].empty() for name in names):
        return None
    mats = {name: node.mat() for name, node in nodes.items() if not node.empty() and node.isMap()}
    size = opencv_image_size(storage.getNode("imageSize"), source)
    if size is None:
        raise CalibrationError(f"{source} has no imageSize; the rectification needs the image size")
    if any(name not in mats for name in names):
        raise CalibrationError(f"{source}: {', '.join(names)} must be opencv-matrix entries")
    translation = np.asarray(mats["T"], dtype=np.float64).ravel()
    # checked in the file's unit, before the calibration's own (0, 100] m: a rig in mm gets the hint
    scale = unit_scale(length_unit, float(np.sqrt((translation ** 2).sum())), source)
    return CameraPairCalibration(
        camera_matrix_left=mats["cameraMatrix1"], distortion_left=mats.get("distCoeffs1"),
        camera_matrix_right=mats["cameraMatrix2"], distortion_right=mats.get("distCoeffs2"),
        rotation=mats["R"], translation_m=translation * scale, width_px=int(size[0]), height_px=int(size[1]))


def read_camera_calibration(path: str | os.PathLike[str], *, length_unit: str | None = None):
    """Read any calibration file: an unrectified camera pair when the file describes one.

    Returns a :class:`CameraPairCalibration` for the project's camera-pair JSON and for OpenCV
    YAML/XML holding ``cameraMatrix1/2``, ``R``, ``T`` (and usually ``distCoeffs1/2``): such a
    file describes the raw cameras, so the images are to be rectified with it (even when it
    also holds ``P1``/``P2``). Every other format goes to
    :func:`stereo_obstacles.calibration_files.read_calibration` and comes back as a rectified
    :class:`~stereo_obstacles.calibration.StereoCalibration`.

    Parameters
    ----------
    path
        The calibration file.
    length_unit
        ``"m"``, ``"cm"`` or ``"mm"``: unit of an OpenCV file's ``T`` (default metres; a
        baseline above ``IMPLAUSIBLE_BASELINE_M`` is then refused with a hint). Not used, with a
        warning, for a file that states its unit (this tool's JSON files).

    Raises
    ------
    InputFileError, CalibrationError
        As :func:`~stereo_obstacles.calibration_files.read_calibration`.
    """
    import cv2

    from stereo_obstacles.calibration_files import (LENGTH_UNITS_M, open_opencv_storage, read_calibration,
                                                    warn_unit_not_used)

    if length_unit is not None and length_unit not in LENGTH_UNITS_M:
        raise CalibrationError(f"length_unit must be one of {sorted(LENGTH_UNITS_M)}, got {length_unit!r}")
    p = Path(path)
    if not p.is_file():
        return read_calibration(p, length_unit=length_unit)  # raises the usual file errors
    head = p.read_bytes()[:4096].decode("utf-8", errors="replace")
    if head.lstrip().startswith("{"):
        try:
            data = json.loads(p.read_text(encoding="utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError):
            data = None
        if is_camera_pair_json(data):
            pair = CameraPairCalibration.from_dict(data, source=str(p))
            warn_unit_not_used(length_unit, p, "a camera calibration of this tool, in metres")
            return pair
    elif "opencv-matrix" in head or "<opencv_storage>" in head or head.lstrip().startswith("%YAML"):
        storage = open_opencv_storage(p)
        try:
            pair = camera_pair_from_opencv_storage(storage, str(p), length_unit) if storage.isOpened() else None
        except cv2.error as exc:  # a node of the wrong kind (a list where a map is expected, a bad matrix)
            raise CalibrationError(f"{p}: malformed OpenCV calibration: {' '.join(exc.msg.split())}") from exc
        finally:
            storage.release()
        if pair is not None:
            return pair
    return read_calibration(p, length_unit=length_unit)
