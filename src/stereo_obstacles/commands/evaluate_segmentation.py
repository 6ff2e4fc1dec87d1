"""``stereo-obstacles evaluate-segmentation``: phase 1 against label ground truth."""

from __future__ import annotations

import argparse

from stereo_obstacles.commands._arguments import image_size, non_negative_int, output_path


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``evaluate-segmentation`` sub-command."""
    parser = subparsers.add_parser(
        "evaluate-segmentation",
        help="score the ground/shadow/obstacle segmentation on synthetic scenes and KITTI",
        description=(
            "Render --scenes random synthetic scenes (ground material, sun direction, obstacles and "
            "a tree shadow drawn per seed) and score phase 1 against their labels, with the "
            "shadow rule on and off: balanced error rate (obstacle vs ground, shadow counting "
            "as ground, sky and markings ignored), obstacle recall, shadow pixels called "
            "obstacle. --dataset folders (KITTI pairs with ground-truth disparity) are scored "
            "against labels derived from the road plane fitted to the ground truth. The left image "
            "is segmented with the stereo ground check on the right image (--colour-only: colour "
            "alone, the paper's phase 1). Prints Markdown tables; --json writes everything."),
    )
    parser.add_argument("--scenes", type=non_negative_int, default=40, metavar="N",
                        help="number of synthetic scenes (seeds 0..N-1 from --first-seed; "
                             "default 40; 0 skips them)")
    parser.add_argument("--first-seed", type=non_negative_int, default=0, metavar="S",
                        help="first seed (default 0)")
    parser.add_argument("--size", default="640x480", metavar="WxH",
                        help="synthetic image size (default 640x480)")
    parser.add_argument("--dataset", "--kitti", dest="kitti", nargs="+", action="extend", default=[], metavar="DIR",
                        help="KITTI folders with a left image and ground-truth disparity (several after one "
                             "--dataset, or --dataset repeated; --kitti is the older name)")
    parser.add_argument("--colour-only", action="store_true",
                        help="segment by colour alone, without the stereo ground check on the right image")
    parser.add_argument("--json", metavar="FILE", default=None, type=output_path,
                        help="also write the results as JSON")
    parser.set_defaults(handler=run)


def _percent(value: float) -> str:
    return "n/a" if value != value else f"{100.0 * value:.2f} %"


def _rows(title: str, groups: dict) -> list[str]:
    from stereo_obstacles.segmentation_evaluation import total

    lines = [f"| {title} | images | shadow rule | BER | obstacle recall | shadow -> obstacle | "
             "ground -> obstacle | marking -> obstacle |",
             "| --- | ---: | --- | ---: | ---: | ---: | ---: | ---: |"]
    for name, scores in groups.items():
        for rule in (True, False):
            c = total(scores, rule=rule)
            lines.append(f"| {name} | {len(scores)} | {'on' if rule else 'off'} | {c.ber_percent:.2f} % | "
                         f"{_percent(c.recall)} | {_percent(c.shadow_to_obstacle_rate)} | "
                         f"{_percent(c.ground_to_obstacle_rate)} | {_percent(c.marking_to_obstacle_rate)} |")
    return lines


def run(args: argparse.Namespace) -> int:
    """Evaluate, print the tables, write the JSON; returns the exit code."""
    import json
    import logging
    import platform
    import sys

    from stereo_obstacles import __version__
    from stereo_obstacles.atomic import check_output_file, write_text_atomic
    from stereo_obstacles.datasets import load_pair
    from stereo_obstacles.errors import InputFileError, InvalidInputError
    from stereo_obstacles.obstacle_json import jsonable
    from stereo_obstacles.segmentation import SegmentationParameters
    from stereo_obstacles.segmentation_evaluation import (KittiTruthParameters, evaluate_synthetic,
                                                          kitti_truth, score_image, total)

    log = logging.getLogger(__name__)
    width, height = image_size(args.size)
    folders = list(dict.fromkeys(args.kitti))            # each once, in the order given
    if args.scenes == 0 and not folders:
        raise InvalidInputError("nothing to evaluate: --scenes 0 and no --dataset")
    if args.json:
        check_output_file(args.json, input_folders=folders)
    pairs = [load_pair(folder, with_calibration=False) for folder in folders]   # a bad folder fails first; no calibration is used
    for folder, pair in zip(folders, pairs):
        if not pair.is_kitti:
            raise InvalidInputError(f"{folder} is a {pair.layout} folder; the labels are derived from the road plane "
                                    f"of a KITTI frame's ground-truth disparity, so only KITTI folders are scored")
        if pair.gt_disparity is None:
            raise InputFileError(f"{folder}: no ground-truth disparity to derive labels from")
    params = SegmentationParameters()
    quiet = not sys.stderr.isatty()

    def progress(score) -> None:
        if not quiet:
            c = score.with_rule
            print(f"  {score.name} ({score.ground}): BER {c.ber_percent:.1f} %", file=sys.stderr)

    stereo = not args.colour_only
    synthetic = evaluate_synthetic(range(args.first_seed, args.first_seed + args.scenes), params=params,
                                   width_px=width, height_px=height, stereo=stereo, progress=progress)
    kitti = []
    truth_params = KittiTruthParameters()
    for pair in pairs:
        truth, plane = kitti_truth(pair.gt_disparity, params=truth_params)
        log.info("%s: road plane %s", pair.name, plane)
        kitti.append(score_image(pair.left, truth, name=pair.name, ground="road", params=params,
                                 right=pair.right if stereo else None))

    lines = [f"Phase 1 with {'colour alone' if args.colour_only else 'colour and the stereo ground check'}.", ""]
    if synthetic:
        by_ground: dict = {"all": synthetic}
        for score in synthetic:
            by_ground.setdefault(score.ground, []).append(score)
        lines += [f"Synthetic scenes ({width}x{height}, seeds {args.first_seed}.."
                  f"{args.first_seed + args.scenes - 1}), pixels pooled:", ""]
        lines += _rows("ground", by_ground) + [""]
    if kitti:
        lines += ["KITTI (labels from the road plane fitted to the ground-truth disparity):", ""]
        lines += _rows("frame", {s.name: [s] for s in kitti} | {"all": kitti}) + [""]
    print("\n".join(lines))
    if args.json:
        report = {"version": __version__, "python": platform.python_version(),
                  "machine": platform.machine(), "size": [width, height],
                  "stereo_ground_check": stereo, "parameters": repr(params), "kitti_truth_parameters": repr(truth_params),
                  "synthetic": [s.summary() for s in synthetic],
                  "synthetic_total": {"shadow_rule_on": total(synthetic).summary(),
                                      "shadow_rule_off": total(synthetic, rule=False).summary()},
                  "kitti": [s.summary() for s in kitti]}
        write_text_atomic(args.json, json.dumps(jsonable(report), indent=2, allow_nan=False) + "\n")   # NaN: null
    return 0
