"""``stereo-obstacles evaluate-detection``: the whole pipeline against ground truth."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from stereo_obstacles.commands._arguments import jpeg_quality, noise_levels, non_negative_int, output_path, positive_metres

if TYPE_CHECKING:  # imported in run(): --help stays instant
    from stereo_obstacles.pipeline import DetectionConfig


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``evaluate-detection`` sub-command."""
    parser = subparsers.add_parser(
        "evaluate-detection", help="obstacles found and distance errors on synthetic scenes; depth on KITTI",
        description="Run detect on rendered synthetic scenes and compare every true obstacle with what was "
                    "found (found rate, distance error against the nearest visible depth, false alarms on "
                    "shadows and markings); on calibrated dataset folders (KITTI), compare depth from our "
                    "disparity with depth from the ground-truth disparity.")
    parser.add_argument("--scenes", type=non_negative_int, default=20, metavar="N",
                        help="synthetic scenes to render (default 20)")
    parser.add_argument("--first-seed", type=non_negative_int, default=0, metavar="S",
                        help="first scene seed (0 = the built-in scene; default 0)")
    parser.add_argument("--size", default="640x480", metavar="WxH", help="synthetic image size (default 640x480)")
    parser.add_argument("--supersample", type=int, default=None, metavar="S", choices=range(1, 5),
                        help="render the scenes with S x S rays per pixel, 1..4 (default 3: a camera pixel "
                             "integrates over its area; with 1 ray thin outlines snap to whole pixels)")
    parser.add_argument("--noise", type=noise_levels, default=0.0, metavar="SIGMA",
                        help="add sensor noise of SIGMA grey levels to the rendered scenes (default 0)")
    parser.add_argument("--jpeg-quality", type=jpeg_quality, default=None, metavar="Q",
                        help="JPEG-compress the rendered pairs at quality Q, 1..100, as a webcam in MJPG "
                             "mode does (default: uncompressed)")
    parser.add_argument("--min-height", type=float, default=0.3, metavar="M",
                        help="count true obstacles at least this high (default 0.3 m)")
    parser.add_argument("--max-distance", type=positive_metres, default=10.0, metavar="M",
                        help="count true obstacles up to this distance (default 10 m)")
    parser.add_argument("--dataset", nargs="+", action="extend", default=[], metavar="DIR",
                        help="calibrated dataset folders (e.g. KITTI) for the depth comparison (several after "
                             "one --dataset, or --dataset repeated)")
    parser.add_argument("--matching-scale", type=float, default=None, metavar="S",
                        help="grow the matches on copies of the pairs shrunk by S in (0, 1] (default: the "
                             "pipeline's, 0.5; see detect)")
    parser.add_argument("--json", metavar="FILE", type=output_path, help="also write the figures as JSON")
    parser.set_defaults(handler=run)


def _dataset_pair(folder: str):
    """The folder's pair, which must have a calibration and a ground-truth disparity (read before
    any scene is evaluated, so that a bad folder fails at once)."""
    from stereo_obstacles.datasets import load_pair
    from stereo_obstacles.errors import InvalidInputError

    pair = load_pair(folder)
    if pair.calibration is None or pair.gt_disparity is None:
        raise InvalidInputError(f"{folder} needs a calibration and a ground-truth disparity for the depth comparison")
    return pair


def _dataset_figures(pair, config: DetectionConfig) -> dict:
    """Depth from ``detect`` (with ``config``) against the pair's ground-truth disparity."""
    from stereo_obstacles.depth_evaluation import depth_agreement
    from stereo_obstacles.pipeline import detect

    result = detect(pair.left, pair.right, pair.calibration, config=config)
    return {"name": pair.name, "density_pct": 100 * result.density,
            "matched": depth_agreement(result.disparity, pair.gt_disparity, pair.calibration).to_dict(),
            "obstacle_pixels": depth_agreement(result.disparity, pair.gt_disparity, pair.calibration,
                                               mask=result.obstacles.id_map > 0).to_dict(),
            "obstacles": len(result.obstacles.obstacles), "timings_s": dict(result.timings_s)}


def run(args: argparse.Namespace) -> int:
    """Evaluate and print the figures."""
    import json
    import logging
    import sys

    from stereo_obstacles.atomic import check_output_file, write_text_atomic
    from stereo_obstacles.commands._arguments import image_size
    from stereo_obstacles.commands._repeated_warnings import each_warning_once, repeats_note
    from stereo_obstacles.errors import InvalidInputError
    from stereo_obstacles.detection_evaluation import (EVALUATION_SUPERSAMPLE, LARGE_ERROR_PCT,
                                                       evaluate_synthetic_scene, summarise)
    from stereo_obstacles.evaluation import machine_info
    from stereo_obstacles.pipeline import DetectionConfig, warm_up
    from stereo_obstacles.scan_evaluation import TOLERANCE_PCT
    from stereo_obstacles.synthetic import RenderOptions

    width, height = image_size(args.size)
    if args.scenes == 0 and not args.dataset:
        raise InvalidInputError("nothing to evaluate: --scenes 0 and no --dataset")
    datasets = list(dict.fromkeys(args.dataset))          # each once, in the order given
    if args.json:
        check_output_file(args.json, input_folders=datasets)
    pairs = [_dataset_pair(folder) for folder in datasets]
    config = DetectionConfig()
    if args.matching_scale is not None:
        config = DetectionConfig(matching_scale=args.matching_scale)
    supersample = EVALUATION_SUPERSAMPLE if args.supersample is None else args.supersample
    imaging = RenderOptions(supersample=supersample, noise_sigma=args.noise, jpeg_quality=args.jpeg_quality)
    warm_up()
    with each_warning_once(not args.verbose) as repeats:   # the same condition in scene after scene
        evaluations = [evaluate_synthetic_scene(seed, width_px=width, height_px=height, config=config,
                                                render_options=imaging, min_height_m=args.min_height)
                       for seed in range(args.first_seed, args.first_seed + args.scenes)]
        datasets = [_dataset_figures(pair, config) for pair in pairs]
    summary = summarise(evaluations, min_height_m=args.min_height, max_distance_m=args.max_distance)
    report = {"machine": machine_info(), "config": config.to_dict(),
              "synthetic": {**summary.to_dict(), "supersample": supersample, "noise_sigma": args.noise,
                            "jpeg_quality": args.jpeg_quality},
              "datasets": datasets}
    s = summary
    if s.n_scenes:
        degraded = "".join([f", noise {args.noise:g}" if args.noise else "",
                            f", JPEG quality {args.jpeg_quality}" if args.jpeg_quality is not None else ""])
        print(f"synthetic scenes {args.first_seed}..{args.first_seed + args.scenes - 1} ({width}x{height}, "
              f"{supersample}x{supersample} rays per pixel{degraded}): "
              f"{s.n_found}/{s.n_obstacles} true obstacles >= {s.min_height_m:g} m high within "
              f"{s.max_distance_m:g} m found")
        if s.n_obstacles == 0:
            logging.getLogger(__name__).warning(
                "no true obstacle of these scenes is %g m high or more within %g m: nothing was scored "
                "(--min-height, --max-distance)", s.min_height_m, s.max_distance_m)
        if s.median_abs_error_pct is not None:
            print(f"  distance error: median {s.median_abs_error_pct:.2f} %, 95th percentile "
                  f"{s.p95_abs_error_pct:.2f} %, worst {s.max_abs_error_pct:.2f} %")
        print(f"  false alarms: {s.false_alarms_on_shadow} on shadows, {s.false_alarms_on_marking} on markings, "
              f"{s.false_alarms_other} elsewhere; median pipeline time {s.median_seconds * 1000:.0f} ms per pair")
        print(f"  detections: {s.n_detections}, of which {s.n_repeated} repeat an obstacle a larger detection covers")
        if s.scan is not None and s.scan.n_with_obstacle:
            c = s.scan
            print(f"  free range per {config.obstacles.scan_sector_deg:g} deg of bearing: {c.n_reported}/"
                  f"{c.n_with_obstacle} sectors with such an obstacle ranged, error median "
                  f"{c.median_abs_error_pct:.2f} %, 95th percentile {c.p95_abs_error_pct:.2f} %, "
                  f"{_frac(c.within_tolerance)} within {TOLERANCE_PCT:g} %; free range overstated in "
                  f"{c.n_overstated}, understated in {c.n_understated} of {c.n_sectors} sectors")
        for miss in s.missed:
            print(f"  missed: {miss}")
        for large in s.large_errors:
            print(f"  error above {LARGE_ERROR_PCT:g} %: {large}")
    for d in report["datasets"]:
        m, o = d["matched"], d["obstacle_pixels"]
        print(f"{d['name']}: density {d['density_pct']:.1f} %; depth vs ground truth over matched pixels: median "
              f"{_pct(m['median_relative_error_pct'])}, {_frac(m['within_5pct'])} within 5 % ({m['compared_px']} px); "
              f"over obstacle pixels: median {_pct(o['median_relative_error_pct'])}, "
              f"{_frac(o['within_5pct'])} within 5 % ({o['compared_px']} px)")
    if repeats():
        print(repeats_note(repeats()), file=sys.stderr)
    if args.json:
        write_text_atomic(args.json, json.dumps(report, indent=2) + "\n")
        print(f"wrote {args.json}")
    return 0


def _pct(value: float | None) -> str:
    return "-" if value is None else f"{value:.2f} %"


def _frac(value: float | None) -> str:
    return "-" if value is None else f"{100 * value:.1f} %"
