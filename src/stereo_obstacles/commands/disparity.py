"""``stereo-obstacles disparity``: a semi-dense disparity map by Growing Correspondence Seeds."""

from __future__ import annotations

import argparse

from stereo_obstacles.commands._arguments import output_path
from stereo_obstacles.commands._calibration_options import add_rectification_options

HELP = "match a rectified stereo pair (GCS) and write its disparity map"


def register(subparsers) -> None:
    """Add the ``disparity`` sub-command."""
    p = subparsers.add_parser("disparity", help=HELP, description=HELP + ". Output format by extension: "
                              ".npy (float32, NaN unmatched), .pfm, or KITTI 16-bit .png.")
    p.add_argument("left", help="left (reference) image")
    p.add_argument("right", help="right image")
    p.add_argument("-o", "--output", required=True, type=output_path, metavar="OUT",
                   help="disparity file (.npy, .pfm or .png)")
    p.add_argument("--seeds", default="sobel", metavar="SEEDS",
                   help="sobel, canny, random, or a text/.npy file of 'x y d' rows (default sobel)")
    p.add_argument("--max-disparity", type=int, default=None, metavar="PX",
                   help="largest disparity, px (default width/3)")
    p.add_argument("--min-disparity", type=int, default=0, metavar="PX",
                   help="smallest disparity, px (default 0)")
    p.add_argument("--tau", type=float, default=0.55, metavar="C",
                   help="similarity threshold (default 0.55; the published method uses 0.6)")
    p.add_argument("--mu", type=float, default=0.05, metavar="C",
                   help="growth margin (default 0.05; the published method uses 0.1)")
    p.add_argument("--max-candidates", type=int, default=4, metavar="K",
                   help="candidates per pixel, K (default 4; the published method uses 10)")
    p.add_argument("--final-margin", type=float, default=0.1, metavar="C", help="stable matching margin (default 0.1)")
    p.add_argument("--variant", choices=("stable", "greedy"), default="stable")
    p.add_argument("--similarity", choices=("ncc", "mncc"), default="ncc")
    p.add_argument("--rng-seed", type=int, default=0, metavar="N", help="random seed for --seeds random")
    p.add_argument("--bands", type=int, default=2, metavar="N",
                   help="row bands grown in parallel threads (default 2; 1: the published single growth)")
    p.add_argument("--shifted-windows", action=argparse.BooleanOptionalAction, default=True,
                   help="reject fattened matches next to depth edges (an extension, on by default; "
                        "--no-shifted-windows --tau 0.6 --mu 0.1 --max-candidates 10 --speckle-size 0 "
                        "is the published method)")
    p.add_argument("--speckle-size", type=int, default=200, metavar="PX",
                   help="remove regions of at most PX matches whose disparity stands apart from their "
                        "surroundings (an extension, default 200; 0 keeps them, as the published method)")
    p.add_argument("--speckle-range", type=float, default=1.0, metavar="PX",
                   help="largest disparity step inside one such region (default 1.0 px)")
    p.add_argument("--picture", default=None, type=output_path, metavar="PICTURE.png",
                   help="also write a turbo picture of the disparity (PNG)")
    p.add_argument("--json", action="store_true", help="print one JSON line of statistics on stdout")
    add_rectification_options(p, with_calib_file=True)
    p.set_defaults(handler=run)


def _seed_points(path: str):
    import warnings
    from pathlib import Path

    import numpy as np

    from stereo_obstacles.errors import InputFileError
    from stereo_obstacles.fileio import read_npy

    p = Path(path)
    if not p.is_file():
        raise InputFileError(f"--seeds: {path} is neither canny, sobel, random nor an existing file")
    if p.suffix.lower() == ".npy":
        return read_npy(p)
    try:
        with warnings.catch_warnings():  # an empty file: NumPy warns, then returns no rows
            warnings.simplefilter("ignore", UserWarning)
            rows = np.loadtxt(p, ndmin=2, comments="#")
    except ValueError as exc:
        raise InputFileError(f"--seeds: {path} is not a text file of 'x y d' rows: {exc}") from exc
    if rows.size == 0:
        raise InputFileError(f"--seeds: {path} holds no 'x y d' rows")
    return rows


def run(args: argparse.Namespace) -> int:
    """Match, write the disparity (and picture), print statistics on request."""
    import json

    from stereo_obstacles.atomic import check_output_file
    from stereo_obstacles.colorize import colorize_disparity
    from stereo_obstacles.commands._compile_notice import announce_compilation
    from stereo_obstacles.fileio import check_disparity_path, check_image_path, read_image, write_disparity, write_image
    from stereo_obstacles.image_pairs import check_pair_of_files, refuse_one_file_twice
    from stereo_obstacles.matching import match, warn_if_range_cut_off
    from stereo_obstacles.seeds import DEFAULT_SEEDS, SEED_SOURCES
    from stereo_obstacles.synthetic.scene_files import refuse_scene_files

    inputs = (args.left, args.right, getattr(args, "calib", None),
              None if args.seeds in SEED_SOURCES else args.seeds)
    check_output_file(args.output, inputs)
    refuse_scene_files(args.output, args.picture)
    check_disparity_path(args.output)
    if args.picture:
        check_output_file(args.picture, inputs + (args.output,))
        check_image_path(args.picture)
    left = read_image(args.left)
    right = read_image(args.right)
    check_pair_of_files(left, right, args.left, args.right, channels=False)
    refuse_one_file_twice(args.left, args.right)
    from stereo_obstacles.commands._calibration_options import prepare_pair

    left, right, _, rectification = prepare_pair(args, left, right)
    announce_compilation()
    named = args.seeds in SEED_SOURCES
    result = match(left, right, seeds=args.seeds if named else DEFAULT_SEEDS,
                   seed_points=None if named else _seed_points(args.seeds),
                   max_disparity=args.max_disparity, min_disparity=args.min_disparity, tau=args.tau, mu=args.mu,
                   max_candidates=args.max_candidates, final_margin=args.final_margin, similarity=args.similarity,
                   variant=args.variant, rng_seed=args.rng_seed, bands=args.bands,
                   shifted_windows=args.shifted_windows, speckle_size=args.speckle_size,
                   speckle_range=args.speckle_range)
    warn_if_range_cut_off(result.disparity, result.stats.d_max, default_limit=args.max_disparity is None)
    write_disparity(args.output, result.disparity)
    if args.picture:
        write_image(args.picture, colorize_disparity(result.disparity, 0, result.stats.d_max))
    if args.json:
        print(json.dumps({"output": str(args.output), **result.stats.to_dict(), "rectification": rectification}))
    else:
        print(f"wrote {args.output}: {100 * result.stats.density:.1f} % of the pixels matched, "
              f"disparities {result.stats.d_min}..{result.stats.d_max} px searched, "
              f"{1000 * result.stats.total_seconds:.0f} ms")
    return 0
