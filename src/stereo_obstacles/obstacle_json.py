"""The obstacles a detection found, as a versioned JSON document a person or a program can read.

The document states its format and version, the units of every number, the coordinate frame
(the rectified left camera: x right, y down, z forward, origin at its optical centre) and the
calibration used. Without a calibration there are no metres: ``"calibration"`` is ``null``,
``"units"`` is ``"pixels"`` and a note says that only image positions and disparities were
measured. Obstacles are listed nearest first with every field of
:class:`~stereo_obstacles.obstacles.Obstacle`; rejected groups carry their reason; the
walking-corridor summary and the free range per direction
(:class:`~stereo_obstacles.direction_scan.DirectionScan`, with a note on its bearings) follow;
documents written before the scan existed have no ``"scan"``. A caller may add its own
context (the resolved configuration, the package version, stage timings, input file names)
under ``"run"``.

Example document (abridged)::

    {"format": "stereo-obstacles/obstacles", "version": 1, "units": "metres",
     "frame": {...}, "calibration": {...}, "image_size_px": {"width": 640, "height": 480},
     "obstacles": [{"id": 1, "distance_m": 4.0, "box_px": [300, 275, 400, 450], ...}],
     "rejected": [{"box_px": [...], "pixel_count": 2250, "reason": "flat on the ground ..."}],
     "corridor": {"width_m": 1.0, "nearest_obstacle_id": 1, "free_distance_m": 4.0},
     "scan": {"sector_deg": 1.0, "first_bearing_deg": -30.0, "field_of_view_deg": [-29.99, 29.91],
              "ranges_m": [null, ..., 4.06, ...], "obstacle_ids": [null, ..., 1, ...], "note": "..."},
     "run": {"package_version": "0.1.0", "config": {...}, "timings_s": {...}, "inputs": {...}}}
"""

from __future__ import annotations

import dataclasses
import enum
import json
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from stereo_obstacles import __version__
from stereo_obstacles.atomic import write_text_atomic
from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.direction_scan import DirectionScan
from stereo_obstacles.errors import CalibrationError, InputFileError, InvalidInputError
from stereo_obstacles.field_checks import is_finite_real
from stereo_obstacles.json_documents import check_document, load_json_file
from stereo_obstacles.obstacles import CorridorSummary, Obstacle, ObstacleList, RejectedGroup

OBSTACLES_FORMAT = "stereo-obstacles/obstacles"
OBSTACLES_VERSION = 1

FRAME = {
    "name": "rectified left camera",
    "x": "right",
    "y": "down",
    "z": "forward (along the optical axis)",
    "origin": "optical centre of the left camera",
    "image_origin": "top-left pixel; box_px is (x0, y0, x1, y1), x1 and y1 exclusive",
}
"""The coordinate frame every 3-D value in the document is expressed in."""

UNITS_NOTE_CALIBRATED = ("Lengths (fields ending in _m) are metres; image positions and disparities "
                         "(fields ending in _px) are pixels.")
UNITS_NOTE_UNCALIBRATED = ("No calibration was given: distances and sizes are unknown. Only image "
                           "positions and disparities are reported, in pixels; a larger disparity "
                           "means a nearer obstacle.")
UNITS_NOTE_RECTIFIED_FROM_IMAGES = (
    "No calibration was given, and the pair was rectified from the images alone: distances and sizes are "
    "unknown. Only image positions and disparities are reported, in pixels; the disparities carry an offset "
    "that changes across the image, so a larger disparity means a nearer obstacle only between obstacles "
    "close together in the image.")


def rectified_from_images(inputs: Mapping[str, Any] | None) -> bool:
    """Whether the run's ``inputs`` (``run.inputs`` of the document) say the pair was rectified
    from its own feature matches (``--uncalibrated``), which leaves no depth scale and an offset
    in the disparity that changes across the image."""
    rectification = inputs.get("rectification") if isinstance(inputs, Mapping) else None
    return isinstance(rectification, Mapping) and rectification.get("method") == "uncalibrated"


def units_note(calibrated: bool, inputs: Mapping[str, Any] | None = None) -> str:
    """What the document's numbers are: metres and pixels, or pixels only (and how far its
    disparities compare when the pair was rectified from the images alone)."""
    if calibrated:
        return UNITS_NOTE_CALIBRATED
    return UNITS_NOTE_RECTIFIED_FROM_IMAGES if rectified_from_images(inputs) else UNITS_NOTE_UNCALIBRATED

SCAN_NOTE = ("Sector k covers bearings [first_bearing_deg + k * sector_deg, first_bearing_deg + (k + 1) * sector_deg) "
             "degrees: the angle atan2(x, z) in the camera's x-z plane, 0 along the optical axis, positive to the "
             "right; the image sees field_of_view_deg. ranges_m[k] is the horizontal range sqrt(x^2 + z^2) in metres "
             "to the nearest obstacle there (obstacle_ids[k]); null: no obstacle reported in that sector.")
"""What the document's ``"scan"`` says about its numbers."""

_TUPLE_FIELDS = ("box_px", "centre_m", "lateral_extent_m", "field_of_view_deg", "ranges_m", "obstacle_ids")


@dataclass(frozen=True)
class ObstacleRecord:
    """The content of an obstacles JSON document, as read back by :func:`read_obstacles_json`.

    Attributes
    ----------
    obstacles : tuple of Obstacle
        Nearest first, as written.
    rejected : tuple of RejectedGroup
        Groups of obstacle pixels that were not reported, with the reason.
    corridor : CorridorSummary or None
        The walking-corridor summary (``None`` without a calibration).
    calibration : StereoCalibration or None
        The calibration used, ``None`` when the results are in pixels.
    image_size_px : tuple of int
        ``(width, height)`` of the left image.
    run : dict
        Caller-given context: ``package_version``, ``config``, ``timings_s``, ``inputs``.
    scan : DirectionScan or None
        The free range per direction (``None`` without a calibration, and in documents written
        before it was added).
    """

    obstacles: tuple[Obstacle, ...]
    rejected: tuple[RejectedGroup, ...]
    corridor: CorridorSummary | None
    calibration: StereoCalibration | None
    image_size_px: tuple[int, int]
    run: dict = field(default_factory=dict)
    scan: DirectionScan | None = None

    @property
    def calibrated(self) -> bool:
        """True when lengths are metres."""
        return self.calibration is not None


def jsonable(value: Any) -> Any:
    """A JSON-ready copy of ``value``: NumPy scalars/arrays, paths, dataclasses, enums; NaN as null."""
    if isinstance(value, bool) or value is None or isinstance(value, (int, str)):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, np.generic):
        return jsonable(value.item())
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, enum.Enum):
        return value.name
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return jsonable(dataclasses.asdict(value))
    if isinstance(value, Mapping):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, set, frozenset)):
        return [jsonable(v) for v in value]
    raise InvalidInputError(f"cannot store a {type(value).__name__} in the obstacles JSON: {value!r}")


def obstacles_to_dict(obstacle_list: ObstacleList, calibration: StereoCalibration | None, *,
                      config: Mapping[str, Any] | None = None,
                      timings_s: Mapping[str, float] | None = None,
                      inputs: Mapping[str, Any] | None = None) -> dict:
    """The JSON document describing a detection, as a plain dictionary.

    Parameters
    ----------
    obstacle_list
        The measured obstacles (nearest first), rejected groups and corridor summary.
    calibration
        The calibration the obstacles were measured with, or ``None`` (pixels only).
    config
        The resolved configuration of the run (any JSON-able mapping; dataclasses, paths,
        NumPy values and enums are converted).
    timings_s
        Seconds spent per stage.
    inputs
        Input file names (or other description of the inputs).

    Returns
    -------
    dict
        JSON-ready: only ``dict``, ``list``, ``str``, ``int``, ``float`` (finite), ``bool``, ``None``.

    Examples
    --------
    >>> import numpy as np
    >>> from stereo_obstacles.obstacles import ObstacleList
    >>> doc = obstacles_to_dict(ObstacleList((), np.zeros((4, 6), np.int32)), None)
    >>> doc["units"], doc["calibration"], doc["image_size_px"]
    ('pixels', None, {'width': 6, 'height': 4})
    """
    if not isinstance(obstacle_list, ObstacleList):
        raise InvalidInputError(f"obstacle_list must be an ObstacleList, got {type(obstacle_list).__name__}")
    if calibration is not None and not isinstance(calibration, StereoCalibration):
        raise InvalidInputError(f"calibration must be a StereoCalibration or None, got {type(calibration).__name__}")
    height, width = np.shape(obstacle_list.id_map)
    calibrated = calibration is not None
    run = {"package_version": __version__}
    for key, extra in (("config", config), ("timings_s", timings_s), ("inputs", inputs)):
        if extra is not None:
            run[key] = jsonable(extra)
    return {
        "format": OBSTACLES_FORMAT,
        "version": OBSTACLES_VERSION,
        "units": "metres" if calibrated else "pixels",
        "units_note": units_note(calibrated, inputs),
        "frame": dict(FRAME),
        "calibration": calibration.to_dict() if calibrated else None,
        "image_size_px": {"width": int(width), "height": int(height)},
        "obstacles": [jsonable(o) for o in obstacle_list.obstacles],
        "rejected": [jsonable(r) for r in obstacle_list.rejected],
        "corridor": jsonable(obstacle_list.corridor),
        "scan": None if obstacle_list.scan is None else {**jsonable(obstacle_list.scan), "note": SCAN_NOTE},
        "run": run,
    }


def write_obstacles_json(path: str | os.PathLike[str], obstacle_list: ObstacleList,
                         calibration: StereoCalibration | None, **extras: Any) -> Path:
    """Write :func:`obstacles_to_dict` to ``path`` (atomically) and return the path.

    ``extras`` are the keyword arguments of :func:`obstacles_to_dict` (``config``,
    ``timings_s``, ``inputs``).
    """
    document = obstacles_to_dict(obstacle_list, calibration, **extras)
    return write_text_atomic(path, json.dumps(document, indent=2, allow_nan=False) + "\n")


def _require(mapping: Any, key: str, kind: type | tuple[type, ...], where: str, source: str) -> Any:
    if not isinstance(mapping, dict) or key not in mapping:
        raise InputFileError(f"{source}: {where} lacks {key!r}")
    value = mapping[key]
    if not isinstance(value, kind):
        raise InputFileError(f"{source}: {where}.{key} has the wrong type ({type(value).__name__})")
    return value


def _from_fields(cls: type, data: Any, where: str, source: str) -> Any:
    """Build a dataclass from its JSON object, turning lists back into tuples."""
    names = [f.name for f in dataclasses.fields(cls)]
    if not isinstance(data, dict):
        raise InputFileError(f"{source}: {where} is not an object")
    unknown = sorted(set(data) - set(names))
    if unknown:
        raise InputFileError(f"{source}: {where} has unknown fields {', '.join(unknown)}")
    values = {k: tuple(v) if k in _TUPLE_FIELDS and isinstance(v, list) else v for k, v in data.items()}
    try:
        return cls(**values)
    except TypeError as exc:
        raise InputFileError(f"{source}: {where}: {exc}") from exc


def _scan(data: Any, calibration: StereoCalibration | None, ids: set[int], source: str) -> DirectionScan:
    """The document's ``"scan"``, which needs a calibration and names listed obstacles only."""
    if not isinstance(data, dict):
        raise InputFileError(f"{source}: scan is not an object")
    if calibration is None:
        raise InputFileError(f"{source}: a scan needs a calibration, and the document has none")
    fields = {k: v for k, v in data.items() if k != "note"}
    if "field_of_view_deg" not in fields and isinstance(fields.get("ranges_m"), list):
        # the scan's first documents (same version 1) did not state the view: all of the sectors
        first, sector = fields.get("first_bearing_deg"), fields.get("sector_deg")
        if is_finite_real(first) and is_finite_real(sector):
            fields["field_of_view_deg"] = [first, first + len(fields["ranges_m"]) * sector]
    try:
        scan = _from_fields(DirectionScan, fields, "scan", source)
    except InvalidInputError as exc:
        raise InputFileError(f"{source}: scan: {exc}") from exc
    unknown = sorted({i for i in scan.obstacle_ids if i is not None} - ids)
    if unknown:
        raise InputFileError(f"{source}: scan names obstacles the document does not list: {unknown}")
    return scan


def read_obstacles_json(path: str | os.PathLike[str]) -> ObstacleRecord:
    """Read a document written by :func:`write_obstacles_json`.

    Raises
    ------
    InputFileError
        The file is missing, is not JSON, is not a ``stereo-obstacles/obstacles`` document, has
        an unsupported version, or lacks required content.
    """
    source = str(path)
    data = check_document(load_json_file(path, what="obstacles"), format_name=OBSTACLES_FORMAT,
                          version=OBSTACLES_VERSION, source=source)
    size = _require(data, "image_size_px", dict, "document", source)
    image_size = (_require(size, "width", int, "image_size_px", source),
                  _require(size, "height", int, "image_size_px", source))
    calibration = None
    if data.get("calibration") is not None:
        try:
            calibration = StereoCalibration.from_dict(data["calibration"], source=f"{source}: calibration")
        except CalibrationError as exc:
            raise InputFileError(str(exc)) from exc
    obstacles = tuple(_from_fields(Obstacle, o, f"obstacles[{i}]", source)
                      for i, o in enumerate(_require(data, "obstacles", list, "document", source)))
    rejected = tuple(_from_fields(RejectedGroup, r, f"rejected[{i}]", source)
                     for i, r in enumerate(_require(data, "rejected", list, "document", source)))
    corridor = data.get("corridor")
    if corridor is not None:
        corridor = _from_fields(CorridorSummary, corridor, "corridor", source)
    scan = data.get("scan")
    if scan is not None:
        scan = _scan(scan, calibration, {o.id for o in obstacles}, source)
    run = data.get("run", {})
    if not isinstance(run, dict):
        raise InputFileError(f"{source}: run is not an object")
    return ObstacleRecord(obstacles=obstacles, rejected=rejected, corridor=corridor,
                          calibration=calibration, image_size_px=image_size, run=run, scan=scan)


__all__ = ["OBSTACLES_FORMAT", "OBSTACLES_VERSION", "FRAME", "ObstacleRecord",
           "obstacles_to_dict", "rectified_from_images", "units_note", "write_obstacles_json", "read_obstacles_json"]
