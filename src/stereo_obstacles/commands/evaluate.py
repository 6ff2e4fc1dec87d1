"""``stereo-obstacles evaluate``: accuracy and speed of the matchers on datasets with ground truth."""

from __future__ import annotations

import argparse

from stereo_obstacles.commands._arguments import output_path, positive_int

def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``evaluate`` sub-command."""
    parser = subparsers.add_parser(
        "evaluate",
        help="compare matchers (ours, OpenCV BM/SGBM, exhaustive NCC) against ground truth",
        description=(
            "Run each method on every stereo pair in the dataset folders and report density, "
            "bad-1/bad-2 over matched non-occluded pixels, the same counting unmatched pixels "
            "as bad, end-point error, KITTI D1 on KITTI pairs, the first-call time and the "
            "median time of --repeat further runs. Every method gets the disparity range of "
            "the ground truth. Folder layouts: see stereo_obstacles.datasets (Middlebury "
            "2001-2014, KITTI, OpenCV samples, 'stereo-obstacles scene' output)."),
    )
    parser.add_argument("datasets", nargs="+", metavar="DATASET_DIR",
                        help="dataset folder; a KITTI 2015 training folder counts as one pair "
                             "per frame")
    parser.add_argument("--methods", default=None, type=_method_list,
                        help="comma-separated methods of the registry in "
                             "stereo_obstacles.evaluation: gcs (ours), sgbm, bm, ncc-wta "
                             "(default: every available one)")
    parser.add_argument("--json", metavar="FILE", default=None, type=output_path,
                        help="also write the full results as JSON to FILE")
    parser.add_argument("--repeat", type=positive_int, default=3, metavar="N",
                        help="timed runs after the first call; the median is reported "
                             "(default 3)")
    parser.add_argument("--max-frames", type=positive_int, default=None, metavar="N",
                        help="evaluate at most N frames of each multi-frame (KITTI) folder")
    parser.set_defaults(handler=run)


def _method_list(text: str) -> list[str]:
    names = [t.strip() for t in text.split(",") if t.strip()]
    if not names:
        raise argparse.ArgumentTypeError("give at least one method")
    return names


def run(args: argparse.Namespace) -> int:
    """Evaluate, print the table, write the JSON report; returns the exit code."""
    import json
    import logging

    from stereo_obstacles.atomic import check_output_file, write_text_atomic
    from stereo_obstacles.datasets import list_frames, load_pair
    from stereo_obstacles.evaluation import (evaluate_pair, format_table, report_dict,
                                             resolve_methods)

    log = logging.getLogger(__name__)
    methods = resolve_methods(args.methods)
    if args.json:
        check_output_file(args.json, input_folders=args.datasets)
    frames = [(folder, frame) for folder in dict.fromkeys(args.datasets)
              for frame in list_frames(folder)[:args.max_frames]]
    results = []
    for folder, frame in frames:
        pair = load_pair(folder, frame=frame, with_calibration=False)     # the matchers need none
        log.info("evaluating %s (%s, %dx%d)", pair.name, pair.layout, pair.left.shape[1],
                 pair.left.shape[0])
        results.extend(evaluate_pair(pair, methods, repeat=args.repeat))
    print(format_table(results))
    print("bad1%/bad2%: over matched non-occluded pixels; bad1u%/bad2u%: unmatched counted as "
          "bad; D1 on KITTI pairs only; first s includes compilation on the first pair; med s: "
          f"median of {args.repeat} runs.")
    if args.json:
        text = json.dumps(report_dict(results, repeat=args.repeat), indent=2, allow_nan=False)
        write_text_atomic(args.json, text + "\n")
        print(f"wrote {args.json}")
    return 0
