"""Command-line options that say how the cameras are calibrated, shared by several commands."""

from __future__ import annotations

import argparse
import logging

CALIB_UNIT_HELP = ("length unit of an OpenCV calibration's translation or of a Q matrix, which the file does not "
                   "say (default m); formats that state theirs do not use it")
"""Help of ``--calib-unit``, for every command that has it."""


def add_calibration_options(parser: argparse.ArgumentParser) -> None:
    """Add ``--calib FILE [--calib-unit U]`` or ``--focal PX --baseline M [--cx --cy --doffs]``."""
    group = parser.add_argument_group(
        "calibration", "how the rectified cameras are calibrated; without any, results stay in pixels")
    group.add_argument("--calib", metavar="FILE",
                       help="calibration file: Middlebury calib.txt, KITTI calib (P_rect), OpenCV YAML/XML "
                            "(P1/P2), a 4x4 Q matrix, or this tool's JSON; or the raw cameras' (OpenCV "
                            "cameraMatrix1/2, distCoeffs1/2, R, T, or calibrate's JSON), which rectifies the images "
                            "first")
    group.add_argument("--calib-unit", choices=["m", "cm", "mm"], help=CALIB_UNIT_HELP)
    group.add_argument("--focal", type=float, metavar="PX", help="focal length in pixels")
    group.add_argument("--baseline", type=float, metavar="M", help="baseline in metres")
    group.add_argument("--cx", type=float, metavar="PX", help="principal point x (default: image centre)")
    group.add_argument("--cy", type=float, metavar="PX", help="principal point y (default: image centre)")
    group.add_argument("--doffs", type=float, metavar="PX",
                       help="x-difference of the principal points, right minus left (Middlebury doffs; default 0)")


def check_manual_calibration(args: argparse.Namespace) -> None:
    """Refuse ``--focal``/``--baseline``/``--cx``/``--cy``/``--doffs`` beside ``--calib``, and
    ``--cx``/``--cy``/``--doffs`` without ``--focal`` and ``--baseline``: they were ignored.

    Raises
    ------
    CalibrationError
        Naming the options that cannot be used.
    """
    from stereo_obstacles.errors import CalibrationError

    manual = [f"--{name}" for name in ("focal", "baseline", "cx", "cy", "doffs")
              if getattr(args, name, None) is not None]
    if getattr(args, "calib", None) and manual:
        raise CalibrationError(f"give either --calib FILE or --focal and --baseline, not both ({', '.join(manual)} "
                               f"given with --calib)")
    if manual and (getattr(args, "focal", None) is None or getattr(args, "baseline", None) is None):
        raise CalibrationError(f"--focal and --baseline must be given together ({', '.join(manual)} given)")


def calibration_from_args(args: argparse.Namespace, width_px: int, height_px: int):
    """The calibration the options describe for images of the given size, or ``None``.

    Raises
    ------
    CalibrationError
        Contradictory or incomplete options, an unreadable file, impossible values, or a
        calibration made for another image size.
    """
    from stereo_obstacles.calibration import StereoCalibration, sized_for_images
    from stereo_obstacles.calibration_files import read_calibration

    check_manual_calibration(args)
    if args.calib:
        calibration = read_calibration(args.calib, length_unit=args.calib_unit)
    elif args.focal is not None:
        calibration = StereoCalibration(
            focal_px=args.focal, baseline_m=args.baseline, doffs_px=args.doffs if args.doffs is not None else 0.0,
            cx_px=args.cx if args.cx is not None else (width_px - 1) / 2.0,
            cy_px=args.cy if args.cy is not None else (height_px - 1) / 2.0,
            width_px=width_px, height_px=height_px)
    else:
        return None
    return sized_for_images(calibration, width_px, height_px)


def add_rectification_options(parser: argparse.ArgumentParser, *, with_calib_file: bool = False) -> None:
    """Add ``--uncalibrated`` (and, for commands without the calibration group, ``--calib FILE``)."""
    group = parser.add_argument_group(
        "rectification", "a calibration with distortion (cameraMatrix/distCoeffs/R/T) rectifies the pair first")
    if with_calib_file:
        group.add_argument("--calib", metavar="FILE",
                           help="calibration file; an unrectified one (OpenCV YAML/XML with cameraMatrix1/2, "
                                "distCoeffs1/2, R, T, or this tool's camera-pair JSON) rectifies the pair first")
        group.add_argument("--calib-unit", choices=["m", "cm", "mm"], help=CALIB_UNIT_HELP)
    group.add_argument("--uncalibrated", action="store_true",
                       help="rectify the pair from its own feature matches (unknown cameras; no metric depth)")


def calibration_and_rectification(args: argparse.Namespace, width_px: int, height_px: int):
    """``(calibration, rectification)`` of the images the options describe: the rectified
    images' calibration (``None`` when unknown) and the
    :class:`~stereo_obstacles.rectification.Rectification` to apply to every pair first when
    ``--calib`` describes the raw cameras (as ``calibrate`` writes them), else ``None``.

    Raises
    ------
    CalibrationError
        As :func:`calibration_from_args`.
    """
    from stereo_obstacles.camera_calibration import read_camera_calibration
    from stereo_obstacles.rectification import rig_for_images

    if not args.calib:
        return calibration_from_args(args, width_px, height_px), None
    check_manual_calibration(args)
    return rig_for_images(read_camera_calibration(args.calib, length_unit=args.calib_unit), width_px, height_px)


def prepare_pair(args: argparse.Namespace, left, right):
    """Rectify the pair as the options say and return ``(left, right, calibration, report)``.

    ``calibration`` is the rectified pair's (``None`` when unknown); ``report`` is a JSON-ready
    dict describing the rectification done, or ``None`` when the pair was taken as rectified.

    Raises
    ------
    CalibrationError, RectificationError
        Contradictory options, a bad calibration, or a pair that cannot be rectified.
    """
    from stereo_obstacles.errors import CalibrationError

    height, width = left.shape[:2]
    calib_file = getattr(args, "calib", None)
    if getattr(args, "uncalibrated", False):
        if calib_file:
            raise CalibrationError("give either --calib FILE or --uncalibrated, not both")
        if getattr(args, "focal", None) is not None or getattr(args, "baseline", None) is not None:
            raise CalibrationError("--uncalibrated gives no metric depth: its homographies shift the disparity by "
                                   "an amount that changes across the image, so --focal and --baseline cannot make "
                                   "distances of it; calibrate the rig (stereo-obstacles calibrate) for distances")
        from stereo_obstacles.uncalibrated_rectification import rectify_uncalibrated

        rectification = rectify_uncalibrated(left, right)
        left, right = rectification.apply(left, right)
        logging.getLogger(__name__).warning(
            "rectified from the images alone: the disparities carry an offset that changes across the image, so "
            "a larger disparity is nearer only between obstacles close together in the image")
        return left, right, None, rectification.to_dict()
    if calib_file:
        calibration, rectification = calibration_and_rectification(args, width, height)
        if rectification is None:
            return left, right, calibration, None
        left, right = rectification.apply(left, right)
        return left, right, calibration, rectification.report(calib_file)
    if not hasattr(args, "focal"):
        return left, right, None, None
    return left, right, calibration_from_args(args, width, height), None
