"""``stereo-obstacles demo``: the built-in scene, detected and compared with its ground truth."""

from __future__ import annotations

import argparse

from stereo_obstacles.commands._arguments import output_path
from stereo_obstacles.commands.detect import add_detection_options


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``demo`` sub-command."""
    parser = subparsers.add_parser(
        "demo", help="render the built-in scene, detect its obstacles, compare with the truth",
        description="Render the built-in synthetic street scene (sun shadows, markings, obstacles at "
                    "known distances), run detect on it, and print each detected obstacle beside the "
                    "true one. The rendered pair and its ground truth go to OUT/scene, the detection "
                    "report to OUT/index.html.")
    parser.add_argument("--out", default="demo_out", type=output_path, metavar="DIR",
                        help="output folder (default demo_out)")
    parser.add_argument("--size", default="640x480", metavar="WxH", help="image size (default 640x480)")
    parser.add_argument("--seed", type=int, default=0, metavar="N",
                        help="0 = the built-in scene (default), other values = a random scene")
    add_detection_options(parser)
    parser.set_defaults(handler=run)


def _comparison_table(comparisons) -> str:
    names = [f"#{c.truth_id} {c.kind} {c.height_m:.2f} m high" for c in comparisons]
    width = max([len("true obstacle"), *map(len, names)])
    lines = [f"{'true obstacle':<{width}} {'true dist.':>10} {'detected':>9} {'distance':>9} {'error':>8}"]
    for name, c in zip(names, comparisons):
        true = f"{c.true_distance_m:.2f} m" if c.true_distance_m is not None else "-"
        if c.detected_id is None:
            lines.append(f"{name:<{width}} {true:>10} {'MISSED':>9} {'-':>9} {'-':>8}")
        else:
            lines.append(f"{name:<{width}} {true:>10} {'#' + str(c.detected_id):>9} "
                         f"{c.detected_distance_m:>7.2f} m {100 * c.relative_error:>+7.1f}%")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    """Render, detect, compare, print."""
    import time
    from pathlib import Path

    from stereo_obstacles.atomic import check_output_folder
    from stereo_obstacles.commands.detect import config_from_args, run_detection, timing_line, warn_if_out_of_reach
    from stereo_obstacles.commands._arguments import image_size
    from stereo_obstacles.commands._compile_notice import announce_compilation
    from stereo_obstacles.detection_evaluation import compare_with_truth
    from stereo_obstacles.errors import InvalidInputError
    from stereo_obstacles.pipeline import warm_up
    from stereo_obstacles.report import check_report_folder, format_obstacle_table
    from stereo_obstacles.synthetic import default_scene, random_scene, render_pair, write_scene_folder
    from stereo_obstacles.synthetic.scene_files import check_scene_folder

    width, height = image_size(args.size)
    config = config_from_args(args)  # every option is checked before anything is written
    check_output_folder(args.out)
    check_report_folder(args.out)
    check_scene_folder(Path(args.out) / "scene")
    if args.seed < 0:
        raise InvalidInputError(f"--seed must be >= 0, got {args.seed}")
    scene = default_scene(width, height) if args.seed == 0 else random_scene(args.seed, width_px=width,
                                                                             height_px=height)
    pair = render_pair(scene)
    warn_if_out_of_reach(config, pair.calibration)
    out = Path(args.out)
    write_scene_folder(out / "scene", pair)
    print(f"rendered the {'built-in' if args.seed == 0 else f'seed {args.seed}'} scene "
          f"({width}x{height}) with its ground truth into {out / 'scene'}")
    announce_compilation()
    started = time.perf_counter()
    warm_up()
    compile_s = time.perf_counter() - started
    result = run_detection(pair.left, pair.right, pair.calibration, config, out,
                           inputs={"left": str(out / "scene" / "left.png"), "right": str(out / "scene" / "right.png"),
                                   "calibration": str(out / "scene" / "calibration.json")})
    print()
    print(format_obstacle_table(result.obstacles, calibrated=True))
    comparisons, alarms = compare_with_truth(result.obstacles, pair.instances, pair.labels, pair.obstacles)
    print()
    print("Against the ground truth (true distance = nearest visible depth):")
    print(_comparison_table(comparisons))
    if alarms:
        for alarm in alarms:
            print(f"false alarm: detection #{alarm.detected_id} lies on {alarm.lies_on}")
    else:
        print("no false alarms (nothing reported on shadows, markings or bare ground)")
    print()
    print(timing_line(result) + f" (compilation before the run: {compile_s:.1f} s, cached after the first run)")
    print(f"wrote {out / 'index.html'}")
    return 0
