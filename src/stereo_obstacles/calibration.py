"""The stereo calibration of a rectified camera pair, and its JSON file format.

A rectified pair is described by the focal length ``focal_px`` (pixels, the same in x and y),
the principal point of the left camera ``(cx_px, cy_px)``, the baseline ``baseline_m``
(metres, distance between the optical centres), Middlebury's ``doffs_px`` (x-difference of
the two principal points, so that depth is ``Z = f B / (d + doffs)``; 0 for most rigs) and
the image size. Depth from disparity is in :mod:`stereo_obstacles.depth`.
"""

from __future__ import annotations

import json
import logging
import math
import os
from dataclasses import asdict, dataclass, replace

from stereo_obstacles.atomic import write_text_atomic
from stereo_obstacles.errors import CalibrationError
from stereo_obstacles.field_checks import plain_numbers
from stereo_obstacles.json_documents import check_document, load_json_file

logger = logging.getLogger(__name__)

CALIBRATION_FORMAT = "stereo-obstacles/calibration"
CALIBRATION_VERSION = 1

MAX_FOCAL_PX = 1e6
"""Largest focal length accepted, pixels: beyond it the field of view of any real image is a
fraction of a degree, so the value is a unit or parsing mistake."""

MIN_FOCAL_PX = 10.0
"""Smallest focal length accepted, pixels: below it even a 16-pixel-wide image would see more
than 77 degrees to either side; a few pixels is a focal length in millimetres."""

PRINCIPAL_POINT_REACH = 10
"""How many image widths (heights) outside the image the principal point may lie."""

OFF_CENTRE_FRACTION = 0.3
"""A principal point farther than this fraction of the image width (height) from the image's
centre is doubtful when the calibration states no image size (:meth:`StereoCalibration.off_centre_doubt`)."""

MIN_BASELINE_M = 0.001
"""Smallest baseline accepted, metres: no stereo rig has its cameras closer than a millimetre; a
smaller value is a baseline in metres given where millimetres are expected (Middlebury's
``baseline``), or a typing slip, and would put every obstacle beyond reach."""


@dataclass(frozen=True)
class StereoCalibration:
    """Calibration of a rectified stereo pair.

    Attributes
    ----------
    focal_px : float
        Focal length in pixels (> 0).
    cx_px, cy_px : float
        Principal point of the left (reference) camera in pixels.
    baseline_m : float
        Distance between the two optical centres in metres (> 0).
    width_px, height_px : int or None
        Image size the calibration belongs to; ``None`` when the source does not record it
        (KITTI's ``calib`` files), in which case any image size is accepted.
    doffs_px : float
        Difference of the principal points' x coordinates (right minus left, Middlebury
        convention), pixels; depth is ``focal_px * baseline_m / (d + doffs_px)``.
    """

    focal_px: float
    cx_px: float
    cy_px: float
    baseline_m: float
    width_px: int | None = None
    height_px: int | None = None
    doffs_px: float = 0.0

    def __post_init__(self) -> None:
        plain_numbers(self)                      # a NumPy scalar (K[0, 0]) as a Python number: JSON-ready
        for name in ("focal_px", "cx_px", "cy_px", "baseline_m", "doffs_px"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
                raise CalibrationError(f"calibration {name} must be a finite number, got {value!r}")
        if self.focal_px <= 0:
            raise CalibrationError(f"calibration focal_px must be > 0, got {self.focal_px}")
        if self.focal_px < MIN_FOCAL_PX:
            raise CalibrationError(f"calibration focal_px = {self.focal_px:g} px is implausible (at least "
                                   f"{MIN_FOCAL_PX:g}; a focal length in pixels, not millimetres)")
        if self.focal_px > MAX_FOCAL_PX:
            raise CalibrationError(f"calibration focal_px = {self.focal_px:g} px is implausible (at most "
                                   f"{MAX_FOCAL_PX:g}; a focal length in pixels, not micrometres)")
        if self.baseline_m <= 0:
            raise CalibrationError(f"calibration baseline_m must be > 0 metres, got {self.baseline_m}")
        if self.baseline_m < MIN_BASELINE_M:
            raise CalibrationError(f"calibration baseline_m = {self.baseline_m:g} m is implausible (at least "
                                   f"{MIN_BASELINE_M:g} m; metres given where millimetres were expected?)")
        if self.baseline_m > 100:
            raise CalibrationError(f"calibration baseline_m = {self.baseline_m} m is implausible "
                                   f"(millimetres given as metres?)")
        for name in ("width_px", "height_px"):
            value = getattr(self, name)
            if value is None:
                continue
            if not isinstance(value, int) or isinstance(value, bool) or value <= 0:
                raise CalibrationError(f"calibration {name} must be a positive integer, got {value!r}")
        if self.width_px is not None and abs(self.doffs_px) >= self.width_px:
            raise CalibrationError(f"calibration doffs_px = {self.doffs_px:g} px is implausible for "
                                   f"{self.width_px} px wide images (|doffs| must be below the width)")

    @property
    def focal_baseline_px_m(self) -> float:
        """``f * B`` in pixel-metres: depth in metres is this divided by ``d + doffs``."""
        return self.focal_px * self.baseline_m

    def check_image_size(self, width_px: int, height_px: int) -> None:
        """Raise :class:`CalibrationError` when the images are not the calibrated size, or the
        principal point lies more than :data:`PRINCIPAL_POINT_REACH` image widths (heights) outside
        them: a slip, or a calibration of other images. (Rectification, or a crop calibrated for
        the whole frame, can put it off the image, but not that far.)"""
        if self.width_px is not None and self.height_px is not None \
                and (width_px, height_px) != (self.width_px, self.height_px):
            raise CalibrationError(
                f"calibration is for {self.width_px}x{self.height_px} images, "
                f"the images are {width_px}x{height_px}")
        reach = PRINCIPAL_POINT_REACH
        if not (-reach * width_px <= self.cx_px <= (reach + 1) * width_px
                and -reach * height_px <= self.cy_px <= (reach + 1) * height_px):
            raise CalibrationError(
                f"calibration principal point ({self.cx_px:g}, {self.cy_px:g}) px lies far outside the "
                f"{width_px}x{height_px} images (a calibration of other images?)")

    def off_centre_doubt(self, width_px: int, height_px: int) -> str | None:
        """A warning sentence when the calibration states no image size and its principal point
        lies more than :data:`OFF_CENTRE_FRACTION` of the width (height) from the centre of
        ``width_px x height_px`` images: most likely a calibration of other images (KITTI's
        ``Calib.txt`` on its images halved puts the principal point in their corner and doubles
        every distance); else None. A warning, not an error: a crop of the calibrated images
        is measured correctly with the whole frame's calibration."""
        if self.width_px is not None and self.height_px is not None:
            return None
        if abs(self.cx_px - (width_px - 1) / 2) <= OFF_CENTRE_FRACTION * width_px \
                and abs(self.cy_px - (height_px - 1) / 2) <= OFF_CENTRE_FRACTION * height_px:
            return None
        return (f"the calibration states no image size, and its principal point ({self.cx_px:g}, {self.cy_px:g}) px "
                f"lies far from the centre of the {width_px}x{height_px} images: if it was made for other images "
                f"(another resolution), every distance is wrong")

    def to_dict(self) -> dict:
        """JSON-ready mapping with the format name and version."""
        return {"format": CALIBRATION_FORMAT, "version": CALIBRATION_VERSION, **asdict(self)}

    @classmethod
    def from_dict(cls, data: dict, *, source: str = "calibration") -> StereoCalibration:
        """Build from :meth:`to_dict` output; raise :class:`CalibrationError` on bad content."""
        check_document(data, format_name=CALIBRATION_FORMAT, version=CALIBRATION_VERSION, source=source,
                       error=CalibrationError)
        fields = ("focal_px", "cx_px", "cy_px", "baseline_m", "width_px", "height_px", "doffs_px")
        missing = [f for f in fields[:4] if f not in data]
        if missing:
            raise CalibrationError(f"{source} lacks {', '.join(missing)}")
        try:
            return cls(**{f: data[f] for f in fields if f in data})
        except TypeError as exc:
            raise CalibrationError(f"{source}: {exc}") from exc


def write_calibration_json(path: str | os.PathLike[str], calibration: StereoCalibration) -> None:
    """Write ``calibration`` as the project's JSON format (atomically)."""
    write_text_atomic(path, json.dumps(calibration.to_dict(), indent=2) + "\n")


def read_calibration_json(path: str | os.PathLike[str]) -> StereoCalibration:
    """Read the project's JSON calibration format; the raw cameras' JSON that ``calibrate`` writes
    is refused with a hint to rectify with it first."""
    from stereo_obstacles.camera_calibration import CAMERA_PAIR_FORMAT

    data = load_json_file(path, what="calibration", error=CalibrationError)
    if isinstance(data, dict) and data.get("format") == CAMERA_PAIR_FORMAT:
        raise CalibrationError(f"{path} is the raw cameras' calibration that calibrate writes, not a rectified "
                               f"rig: read it with camera_calibration.read_camera_calibration and rectify the images "
                               f"with it (rectification.rectify_calibration); the commands do both with --calib")
    return StereoCalibration.from_dict(data, source=str(path))


def sized_for_images(calibration: StereoCalibration, width_px: int, height_px: int, *,
                     source: object = None) -> StereoCalibration:
    """``calibration`` checked against images of ``width_px x height_px``
    (:meth:`StereoCalibration.check_image_size`; its :meth:`~StereoCalibration.off_centre_doubt`
    logged as a warning) and with their size filled in when it states none, so that the check and
    the warning come once per pair of files or per stream, not again in every
    :func:`~stereo_obstacles.pipeline.detect` call. ``source`` (a dataset folder) starts the warning."""
    calibration.check_image_size(width_px, height_px)
    doubt = calibration.off_centre_doubt(width_px, height_px)
    if doubt is not None:
        logger.warning("%s", doubt if source is None else f"{source}: {doubt}")
    if calibration.width_px is None or calibration.height_px is None:
        calibration = replace(calibration, width_px=width_px, height_px=height_px)
    return calibration
