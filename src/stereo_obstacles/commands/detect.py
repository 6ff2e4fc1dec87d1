"""``stereo-obstacles detect``: obstacles with distances from a rectified colour stereo pair."""

from __future__ import annotations

import argparse

from stereo_obstacles.commands._arguments import output_path, positive_int, positive_metres
from stereo_obstacles.commands._calibration_options import add_calibration_options, add_rectification_options


def add_detection_options(parser: argparse.ArgumentParser) -> None:
    """Options of the pipeline stages, shared by ``detect`` and ``demo``."""
    group = parser.add_argument_group("detection")
    group.add_argument("--max-disparity", type=positive_int, default=None, metavar="PX",
                       help="largest disparity to search, pixels (default: a third of the width)")
    group.add_argument("--seeds", choices=("canny", "sobel", "random"), default=None,
                       help="where the matcher's seeds come from (default sobel)")
    group.add_argument("--reference", default=None, metavar="X0,Y0,X1,Y1",
                       help="rectangle assumed to be ground, in fractions of the image (all <= 1) "
                            "or pixels (default: the full-width bottom 15 %%, 0,0.85,1,1)")
    group.add_argument("--corridor-width", type=positive_metres, default=None, metavar="M",
                       help="width of the walking corridor straight ahead, metres (default 1.0)")
    group.add_argument("--max-distance", type=positive_metres, default=None, metavar="M",
                       help="look for obstacles up to this distance, metres (default 30; farther pixels are left out)")
    group.add_argument("--matching-scale", type=float, default=None, metavar="S",
                       help="grow the matches on a copy of the pair shrunk by S in (0, 1], then refine "
                            "them at full size (default 0.5; 1 grows at full size, about 1.3x slower)")


def config_from_args(args: argparse.Namespace):
    """The :class:`~stereo_obstacles.pipeline.DetectionConfig` the options describe."""
    from dataclasses import replace

    from stereo_obstacles.pipeline import DetectionConfig, MatchingOptions
    from stereo_obstacles.reference_area import ReferenceArea

    config = DetectionConfig(matching=MatchingOptions(seeds=args.seeds, max_disparity=args.max_disparity))
    if args.matching_scale is not None:
        config = replace(config, matching_scale=args.matching_scale)
    if args.reference is not None:
        config = replace(config, reference=ReferenceArea.parse(args.reference))
    obstacle_changes = {name: value for name, value in (("corridor_width_m", args.corridor_width),
                                                        ("max_distance_m", args.max_distance)) if value is not None}
    if obstacle_changes:
        config = replace(config, obstacles=replace(config.obstacles, **obstacle_changes))
    return config


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``detect`` sub-command."""
    parser = subparsers.add_parser(
        "detect", help="obstacles with distances from a rectified colour stereo pair",
        description="Find the obstacles in a rectified colour stereo pair: phase-1 ground/shadow/obstacle "
                    "segmentation, GCS matching, depth, obstacles grouped and measured. Prints the "
                    "obstacles nearest first and writes obstacles.json, disparity.pfm, depth.npy, labels.png, "
                    "points.ply, pictures and index.html to the output folder.")
    parser.add_argument("left", help="left (reference) colour image")
    parser.add_argument("right", help="right colour image")
    parser.add_argument("--out", required=True, type=output_path, metavar="DIR",
                        help="output folder (created if needed)")
    add_calibration_options(parser)
    add_rectification_options(parser)
    add_detection_options(parser)
    parser.set_defaults(handler=run)


def warn_if_out_of_reach(config, calibration) -> None:
    """Log a warning when ``--max-disparity`` puts every obstacle within ``--max-distance`` out of
    reach: the nearest depth it can measure, ``f B / (max_disparity + doffs)``, lies beyond it."""
    import logging

    max_disparity = config.matching.max_disparity
    if calibration is None or max_disparity is None:
        return
    nearest_m = calibration.focal_baseline_px_m / (max_disparity + calibration.doffs_px) \
        if max_disparity + calibration.doffs_px > 0 else float("inf")
    if nearest_m > config.obstacles.max_distance_m:
        logging.getLogger(__name__).warning(
            "--max-disparity %d px measures nothing nearer than %.1f m, beyond the %.0f m obstacles are "
            "reported to: no obstacle can be found", max_disparity, nearest_m, config.obstacles.max_distance_m)


def run_detection(left, right, calibration, config, out_dir, inputs: dict):
    """Detect, write every output into ``out_dir``, and return the detection result; a pair
    that looks swapped is refused before anything is written. The rectification check's
    verdict is stored with the ``inputs`` (``obstacles.json``'s ``run.inputs.rectification_check``:
    a reader can tell a pair that is not rectified, or could not be checked)."""
    from stereo_obstacles.pipeline import detect
    from stereo_obstacles.rectification_check import refuse_swapped, refusing_swapped_pairs
    from stereo_obstacles.report import write_detection_outputs

    with refusing_swapped_pairs():
        result = detect(left, right, calibration, config=config)
    refuse_swapped(result.rectification_check)
    if result.rectification_check is not None:
        inputs = {**inputs, "rectification_check": result.rectification_check.to_dict()}
    write_detection_outputs(out_dir, left=left, labels=result.segmentation.labels, disparity=result.disparity,
                            depth_m=result.depth_m, obstacle_list=result.obstacles, calibration=calibration,
                            config=config.to_dict(), timings=result.timings_s, inputs=inputs)
    return result


BESIDE_MATCHING = ("segmentation", "rectification_check")
"""Stages that :func:`stereo_obstacles.pipeline.detect` runs on a second thread beside the matching."""


def timing_line(result) -> str:
    """One line with the milliseconds spent per stage (wall time of each; the stages run beside
    the matching overlap it, so the stages add up to more than the total)."""
    stages = [f"{name} {seconds * 1000:.0f} ms" for name, seconds in result.timings_s.items()]
    names = list(result.timings_s)
    if all(name in names for name in BESIDE_MATCHING + ("matching",)):
        last = max(names.index(name) for name in BESIDE_MATCHING)
        stages[last] += " (these two beside the matching)"
    return "time: " + ", ".join(stages)


def run(args: argparse.Namespace) -> int:
    """Read the pair, detect, write the outputs, print the table."""
    from pathlib import Path

    from stereo_obstacles.atomic import check_output_folder
    from stereo_obstacles.commands._compile_notice import announce_compilation
    from stereo_obstacles.fileio import read_image
    from stereo_obstacles.image_pairs import check_pair_of_files, refuse_one_file_twice
    from stereo_obstacles.report import OUTPUT_FILES, check_report_folder, format_obstacle_table

    check_output_folder(args.out, OUTPUT_FILES, inputs=(args.left, args.right, args.calib))
    check_report_folder(args.out)
    left = read_image(args.left, mode="color")
    right = read_image(args.right, mode="color")
    check_pair_of_files(left, right, args.left, args.right)
    refuse_one_file_twice(args.left, args.right)
    from stereo_obstacles.commands._calibration_options import prepare_pair

    left, right, calibration, rectification = prepare_pair(args, left, right)
    config = config_from_args(args)
    warn_if_out_of_reach(config, calibration)
    announce_compilation()
    result = run_detection(left, right, calibration, config, args.out,
                           inputs={"left": str(args.left), "right": str(args.right),
                                   "calibration": args.calib, "rectification": rectification})
    print(format_obstacle_table(result.obstacles, calibration is not None, inputs={"rectification": rectification}))
    print(timing_line(result) + " (one call in a fresh process: includes loading the compiled kernels)")
    print(f"wrote {Path(args.out) / 'index.html'} and the data files beside it")
    return 0
