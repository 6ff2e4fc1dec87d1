"""``stereo-obstacles rectify``: rectify a stereo pair with a calibration or from its own matches."""

from __future__ import annotations

import argparse

from stereo_obstacles.commands._arguments import output_path
from stereo_obstacles.commands._calibration_options import CALIB_UNIT_HELP

REPORT_FORMAT = "stereo-obstacles/rectification"
"""The ``format`` of ``rectification.json``: how a later run knows the folder holds its output."""

REPORT_VERSION = 1
"""The version of that format, a whole number as every other document's (the package version
that wrote it is ``package_version``)."""

OUTPUT_FILES = ("left.png", "right.png", "calibration.json", "rectification.json")
"""What ``rectify`` writes into its folder: the rectified pair, the rectified calibration
(calibrated case) and the quality report."""

HELP = "rectify a stereo pair (calibrated or uncalibrated) and report how well"


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``rectify`` sub-command."""
    parser = subparsers.add_parser(
        "rectify", help=HELP,
        description=HELP + ". Writes left.png and right.png (rectified), calibration.json (the rectified "
                    "pair's calibration, calibrated case) and rectification.json (the quality: median and 95th "
                    "percentile vertical offset of matched features, pixels) to the output folder.")
    parser.add_argument("left", help="left image")
    parser.add_argument("right", help="right image")
    how = parser.add_mutually_exclusive_group(required=True)
    how.add_argument("--calib", metavar="FILE",
                     help="unrectified calibration: OpenCV YAML/XML (cameraMatrix1/2, distCoeffs1/2, R, T) or "
                          "this tool's camera-pair JSON (from stereo-obstacles calibrate)")
    how.add_argument("--uncalibrated", action="store_true",
                     help="rectify from feature matches and a robust fundamental matrix")
    parser.add_argument("--calib-unit", choices=["m", "cm", "mm"],
                        help=CALIB_UNIT_HELP)
    parser.add_argument("--out", required=True, type=output_path, metavar="DIR",
                        help="output folder (created if needed)")
    parser.set_defaults(handler=run)


def _is_rectify_report(path) -> bool:
    """Whether ``path`` is a ``rectification.json`` this command wrote: of its format, or of the
    shape it had before it carried one (a ``rectification`` beside ``features_after``)."""
    import json

    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError):
        return False
    return isinstance(data, dict) and (data.get("format") == REPORT_FORMAT or {
        "version", "rectification", "features_before", "features_after"} <= data.keys())


def run(args: argparse.Namespace) -> int:
    """Rectify, measure, write the set of files atomically, print the report."""
    import json
    import logging
    from pathlib import Path

    import numpy as np

    from stereo_obstacles import __version__
    from stereo_obstacles.atomic import check_output_folder, moved_in_files, refuse_foreign_files, staged_directory
    from stereo_obstacles.calibration import write_calibration_json
    from stereo_obstacles.camera_calibration import CameraPairCalibration, read_camera_calibration
    from stereo_obstacles.errors import CalibrationError, ImageMismatchError, OutputError
    from stereo_obstacles.fileio import read_image, write_image
    from stereo_obstacles.image_pairs import check_pair_of_files
    from stereo_obstacles.rectification_check import check_rectification, refuse_swapped
    from stereo_obstacles.synthetic.scene_files import holds_a_scene

    check_output_folder(args.out, OUTPUT_FILES, inputs=(args.left, args.right, args.calib))
    if holds_a_scene(args.out):
        raise OutputError(f"{args.out} holds a rendered scene: its left.png, right.png and calibration.json go with "
                          f"its ground truth; write the rectified pair elsewhere")
    earlier_run = _is_rectify_report(Path(args.out) / "rectification.json")
    refuse_foreign_files(args.out, OUTPUT_FILES, ours=earlier_run, what="rectification",
                         missing="no rectification.json of it")
    left = read_image(args.left)
    right = read_image(args.right)
    check_pair_of_files(left, right, args.left, args.right)
    if np.array_equal(left, right):                # "they look swapped" or "degenerate motion" said it badly
        raise ImageMismatchError(f"{args.left} and {args.right} are the same image; rectifying needs the two "
                                 f"cameras' images")
    report = {"format": REPORT_FORMAT, "version": REPORT_VERSION, "package_version": __version__,
              "left": str(args.left), "right": str(args.right)}
    rectified_calibration = None
    if args.uncalibrated:
        from stereo_obstacles.uncalibrated_rectification import rectify_uncalibrated

        rectification = rectify_uncalibrated(left, right)
        new_left, new_right = rectification.apply(left, right)
        report["rectification"] = rectification.to_dict()
    else:
        from stereo_obstacles.rectification import rectify_calibration

        calibration = read_camera_calibration(args.calib, length_unit=args.calib_unit)
        if not isinstance(calibration, CameraPairCalibration):
            raise CalibrationError(f"{args.calib} is the calibration of an already rectified pair (no camera "
                                   f"matrices, distortion, R and T): there is nothing to rectify")
        calibration.check_image_size(left.shape[1], left.shape[0])
        rectification = rectify_calibration(calibration)
        new_left, new_right = rectification.apply(left, right)
        rectified_calibration = rectification.rectified
        report["rectification"] = rectification.report(args.calib)
    before = check_rectification(left, right, warn=False)
    after = check_rectification(new_left, new_right, warn=False)
    report["features_before"] = before.to_dict()
    report["features_after"] = after.to_dict()
    refuse_swapped(after)       # rectified with the calibration, the features say the images were exchanged
    # an earlier calibrated run's calibration.json would describe images this run replaces (one
    # whose move was cut short too: review, session 24)
    earlier_part = "calibration.json" in moved_in_files(args.out, "rectification")
    stale = ("calibration.json",) if rectified_calibration is None and (earlier_run or earlier_part) else ()
    with staged_directory(args.out, last=("rectification.json",), stale=stale,
                          kind="rectification") as stage:   # rectification.json vouches for the set
        write_image(stage / "left.png", new_left)
        write_image(stage / "right.png", new_right)
        if rectified_calibration is not None:
            write_calibration_json(stage / "calibration.json", rectified_calibration)
        (stage / "rectification.json").write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
    print(f"before: {before.offsets.describe()}")
    print(f"after:  {after.offsets.describe()}")
    if args.uncalibrated:
        low, high = rectification.disparity_range_px
        print(f"inliers: {rectification.n_inliers} of {rectification.n_matches} matches; their "
              f"{rectification.quality.describe()}; disparities {low:.1f}..{high:.1f} px")
        if rectification.unchanged:
            print("the pair is rectified already: its images are written as they are")
    else:
        print(f"rectified: focal {rectified_calibration.focal_px:.2f} px, baseline "
              f"{rectified_calibration.baseline_m:.4f} m, principal point ({rectified_calibration.cx_px:.1f}, "
              f"{rectified_calibration.cy_px:.1f}) px")
    if after.rectified is False:
        logging.getLogger(__name__).warning("the rectified pair still shows a vertical offset above %g px; check "
                                            "the calibration", after.threshold_px)
    print(f"wrote {args.out}")
    return 0
