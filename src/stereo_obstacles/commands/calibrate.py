"""``stereo-obstacles calibrate``: stereo calibration from chessboard image pairs."""

from __future__ import annotations

import argparse
import re
from pathlib import Path

from stereo_obstacles.commands._arguments import output_path, positive_metres

HELP = "calibrate a stereo rig from chessboard image pairs"


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``calibrate`` sub-command."""
    parser = subparsers.add_parser(
        "calibrate", help=HELP,
        description=HELP + ". Finds the board in every pair (pairs where it is not found in both images are "
                    "rejected and named), calibrates both cameras and the pair, and writes the calibration as "
                    "this tool's JSON (FILE) and as OpenCV YAML beside it (FILE with .yml; translation in "
                    "metres), with the RMS reprojection error and the vertical offsets of the corners after "
                    "rectification (the epipolar error).")
    parser.add_argument("left_glob", nargs="?", metavar="LEFT_GLOB", help="left images, e.g. 'left*.jpg' (quoted)")
    parser.add_argument("right_glob", nargs="?", metavar="RIGHT_GLOB", help="right images in the same order")
    parser.add_argument("--folder", metavar="DIR",
                        help="instead of globs: a folder whose files named *left*/*right* form the pairs")
    parser.add_argument("--board", default="9x6", metavar="CxR",
                        help="inner corners per row x per column (default 9x6)")
    parser.add_argument("--square", type=positive_metres, required=True, metavar="M", help="side of a square, metres")
    parser.add_argument("--out", required=True, type=output_path, metavar="FILE",
                        help="calibration JSON to write (.json); the OpenCV YAML is written beside it as FILE with .yml")
    parser.add_argument("--json", action="store_true", help="print the report as one JSON line")
    parser.set_defaults(handler=run)


IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".ppm", ".pgm")


def _side_word(name: str, side: str) -> re.Match | None:
    """Where ``side`` (``left`` or ``right``, any case) first stands in ``name`` as a word of its
    own: at the start, after a non-letter, or capitalised after a small letter (``camLeft``); not
    the end of a longer word (``bright``, ``copyright``)."""
    for match in re.finditer(side, name, flags=re.IGNORECASE):
        i = match.start()
        if i == 0 or not name[i - 1].isalpha() or (name[i].isupper() and name[i - 1].islower()):
            return match
    return None


def _pairs_from_folder(folder: str) -> list[tuple[str, str]]:
    """The image pairs of ``folder`` whose names differ only in ``left``/``right`` (any case), in
    name order; a warning names the files without a partner, which are left out."""
    import logging

    from stereo_obstacles.errors import InputFileError

    root = Path(folder)
    if not root.is_dir():
        raise InputFileError(f"--folder {folder} is not a folder")
    images = sorted(p for p in root.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES and p.is_file())
    rights = {p.name.lower(): p for p in images if _side_word(p.name, "right")}
    pairs, unpaired = [], []
    for left in (p for p in images if _side_word(p.name, "left")):
        word = _side_word(left.name, "left")
        right = rights.pop((left.name[:word.start()] + "right" + left.name[word.end():]).lower(), None)
        if right is None:
            unpaired.append(left.name)
        else:
            pairs.append((str(left), str(right)))
    unpaired += [p.name for p in rights.values()]
    if not pairs:
        raise InputFileError(f"--folder {folder} holds no image pairs named *left*/*right*")
    if unpaired:
        logging.getLogger(__name__).warning(
            "%d image%s in %s %s no partner of the other camera and %s left out: %s", len(unpaired),
            "s" if len(unpaired) != 1 else "", folder, "have" if len(unpaired) != 1 else "has",
            "are" if len(unpaired) != 1 else "is", ", ".join(sorted(unpaired)))
    return pairs


def _pairs_from_globs(left_glob: str, right_glob: str) -> list[tuple[str, str]]:
    """The files the two patterns match, paired in natural order (``left2`` before ``left11``);
    refused when the counts differ, a file stands on both sides, or the frame numbers of the
    pairs fall out of step (a file missing on one side: ``streams.first_out_of_step``)."""
    import glob
    import os

    from stereo_obstacles.errors import InputFileError
    from stereo_obstacles.streams import first_out_of_step, natural_key, relative_paths

    lefts, rights = (sorted(glob.glob(pattern), key=natural_key) for pattern in (left_glob, right_glob))
    if not lefts or not rights:
        raise InputFileError(f"no files match {left_glob if not lefts else right_glob}")
    if len(lefts) != len(rights):
        raise InputFileError(f"{left_glob} matches {len(lefts)} files but {right_glob} matches {len(rights)}; "
                             f"the pairs must correspond one to one")
    for left, right in zip(lefts, rights):
        if os.path.realpath(left) == os.path.realpath(right):
            raise InputFileError(f"{left_glob} and {right_glob} both match {left}: the left and right images of a "
                                 f"pair must be the two cameras' own")
    out_of_step = first_out_of_step(*(relative_paths([Path(f) for f in files]) for files in (lefts, rights)))
    if out_of_step is not None:
        raise InputFileError(f"{lefts[out_of_step]} is paired with {rights[out_of_step]} (the files in order): their "
                             f"frame numbers are out of step with the first pair's; is a file missing on one side?")
    return list(zip(lefts, rights))


def _written_by_calibrate(yaml_path: Path, json_path: Path) -> bool:
    """Whether the OpenCV YAML ``yaml_path`` is one an earlier ``calibrate`` wrote: it carries the
    tool's comment, or (written before the comment was) it holds the camera matrices and
    translation of the camera-pair JSON ``json_path`` beside it (a user's own ``stereo.yml`` of
    another calibration does not)."""
    import cv2
    import numpy as np

    from stereo_obstacles.camera_calibration import is_marked_opencv_file, read_camera_pair_json
    from stereo_obstacles.errors import StereoObstaclesError

    if is_marked_opencv_file(yaml_path):
        return True
    try:
        written = read_camera_pair_json(json_path)
    except StereoObstaclesError:
        return False
    storage = cv2.FileStorage(str(yaml_path), cv2.FILE_STORAGE_READ)
    try:
        matrices = [storage.getNode(name).mat() if storage.isOpened() else None
                    for name in ("cameraMatrix1", "cameraMatrix2", "T")]
    except cv2.error:
        return False
    finally:
        storage.release()
    expected = (written.camera_matrix_left, written.camera_matrix_right, written.translation_m.reshape(3, 1))
    return all(m is not None and m.shape == e.shape and np.allclose(m, e) for m, e in zip(matrices, expected))


def run(args: argparse.Namespace) -> int:
    """Find the boards, calibrate, write JSON + YAML, print the report."""
    import json

    from stereo_obstacles.atomic import check_output_file, refuse_foreign_file
    from stereo_obstacles.camera_calibration import write_camera_pair_json, write_opencv_yaml
    from stereo_obstacles.chessboard_calibration import Board, calibrate_pairs
    from stereo_obstacles.errors import InvalidInputError, OutputError
    from stereo_obstacles.fileio import read_image
    from stereo_obstacles.synthetic.scene_files import refuse_scene_files

    if args.folder and (args.left_glob or args.right_glob):
        raise InvalidInputError("give either LEFT_GLOB RIGHT_GLOB or --folder DIR, not both")
    if not args.folder and not (args.left_glob and args.right_glob):
        raise InvalidInputError("give LEFT_GLOB and RIGHT_GLOB, or --folder DIR")
    out = Path(args.out)
    if out.suffix.lower() != ".json":
        raise OutputError(f"--out {out} must end in .json (the OpenCV YAML is written beside it)")
    board = Board.parse(args.board, args.square)
    files = _pairs_from_folder(args.folder) if args.folder else _pairs_from_globs(args.left_glob, args.right_glob)
    yaml_path = out.with_suffix(".yml")
    images = tuple(name for pair in files for name in pair)
    check_output_file(out, images)
    check_output_file(yaml_path, images)
    refuse_foreign_file(yaml_path, ours=lambda path: _written_by_calibrate(path, out), what="calibration YAML")
    refuse_scene_files(out)
    pairs = [(f"{Path(left).name}+{Path(right).name}", read_image(left, mode="gray"), read_image(right, mode="gray"))
             for left, right in files]
    result = calibrate_pairs(pairs, board)
    # the YAML first: cut short between the two, a marked YAML stands beside an older JSON, which a
    # rerun takes for its own (the other way round an older, unmarked YAML would be refused)
    write_opencv_yaml(yaml_path, result.calibration, result.rectification.opencv_matrices())
    write_camera_pair_json(out, result.calibration)
    report = {"calibration": str(out), "opencv_yaml": str(yaml_path), **result.to_dict()}
    if args.json:
        print(json.dumps(report))
        return 0
    print(f"pairs used: {len(result.used)} of {len(pairs)}")
    for reason in result.rejected:
        print(f"rejected: {reason}")
    print(f"RMS reprojection error: {result.rms_px:.3f} px (left camera alone {result.rms_left_px:.3f} px, "
          f"right {result.rms_right_px:.3f} px)")
    print(f"epipolar error after rectification: {result.epipolar.describe()}")
    rectified = result.rectification.rectified
    print(f"baseline {result.calibration.baseline_m:.4f} m; rectified focal {rectified.focal_px:.1f} px, "
          f"principal point ({rectified.cx_px:.1f}, {rectified.cy_px:.1f}) px")
    print(f"wrote {out} and {yaml_path}")
    return 0
