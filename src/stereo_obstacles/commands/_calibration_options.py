"""Command-line options that say how the cameras are calibrated, shared by several commands."""

from __future__ import annotations

import argparse


def add_calibration_options(parser: argparse.ArgumentParser) -> None:
    """Add ``--calib FILE [--calib-unit U]`` or ``--focal PX --baseline M [--cx --cy --doffs]``."""
    group = parser.add_argument_group(
        "calibration", "how the rectified cameras are calibrated; without any, results stay in pixels")
    group.add_argument("--calib", metavar="FILE",
                       help="calibration file: Middlebury calib.txt, KITTI calib (P_rect), OpenCV YAML/XML "
                            "(P1/P2), a 4x4 Q matrix, or this tool's JSON")
    group.add_argument("--calib-unit", choices=["m", "cm", "mm"],
                       help="length unit of an OpenCV calibration's translation (the file does not say)")
    group.add_argument("--focal", type=float, metavar="PX", help="focal length in pixels")
    group.add_argument("--baseline", type=float, metavar="M", help="baseline in metres")
    group.add_argument("--cx", type=float, metavar="PX", help="principal point x (default: image centre)")
    group.add_argument("--cy", type=float, metavar="PX", help="principal point y (default: image centre)")
    group.add_argument("--doffs", type=float, default=0.0, metavar="PX",
                       help="x-difference of the principal points, right minus left (Middlebury doffs)")


def calibration_from_args(args: argparse.Namespace, width_px: int, height_px: int):
    """The calibration the options describe for images of the given size, or ``None``.

    Raises
    ------
    CalibrationError
        Contradictory or incomplete options, an unreadable file, impossible values, or a
        calibration made for another image size.
    """
    from stereo_obstacles.calibration import StereoCalibration
    from stereo_obstacles.calibration_files import read_calibration
    from stereo_obstacles.errors import CalibrationError

    manual = args.focal is not None or args.baseline is not None
    if args.calib and manual:
        raise CalibrationError("give either --calib FILE or --focal and --baseline, not both")
    if args.calib:
        calibration = read_calibration(args.calib, length_unit=args.calib_unit)
    elif manual:
        if args.focal is None or args.baseline is None:
            raise CalibrationError("--focal and --baseline must be given together")
        calibration = StereoCalibration(
            focal_px=args.focal, baseline_m=args.baseline, doffs_px=args.doffs,
            cx_px=args.cx if args.cx is not None else (width_px - 1) / 2.0,
            cy_px=args.cy if args.cy is not None else (height_px - 1) / 2.0,
            width_px=width_px, height_px=height_px)
    else:
        return None
    calibration.check_image_size(width_px, height_px)
    return calibration
