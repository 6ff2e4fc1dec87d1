"""``stereo-obstacles segment``: phase 1 alone, ground / shadow / obstacle labels of one image."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from stereo_obstacles.commands._arguments import output_path

if TYPE_CHECKING:
    from pathlib import Path

    from stereo_obstacles.ground_check import GroundCheck


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``segment`` sub-command."""
    parser = subparsers.add_parser(
        "segment",
        help="label ground, ground in shadow and obstacles in one colour image (phase 1)",
        description=(
            "Shadow-robust colour segmentation: the ground's colours (log-RGB by default, HSI "
            "as in the paper with --colour-model hsi) are measured in a reference rectangle in front of "
            "the camera; every pixel becomes ground (1), "
            "shadow (2, ground in shadow), obstacle (3) or unknown (0). The labels are written "
            "as an 8-bit PNG; --overlay writes a picture for people. With --right (the right image "
            "of a rectified pair) pixels that the right image does not see on the ground plane "
            "become obstacles whatever their colour. See docs/segmentation.md."),
    )
    parser.add_argument("image", metavar="IMAGE", help="colour image (left camera)")
    parser.add_argument("--right", metavar="RIGHT", default=None,
                        help="right image of the rectified pair: adds the stereo ground check")
    parser.add_argument("-o", "--output", required=True, type=output_path, metavar="LABELS.png",
                        help="label image to write (uint8 PNG with the values above); a JSON record of "
                             "the run is written beside it as LABELS.png.json")
    parser.add_argument("--overlay", metavar="PICTURE.png", default=None, type=output_path,
                        help="also write the image with the labels blended over it")
    parser.add_argument("--reference", metavar="X0,Y0,X1,Y1", default=None,
                        help="ground reference rectangle, in pixels or, when every value is <= 1, "
                             "in fractions of the image (default: the full-width bottom 15 %%, "
                             "0,0.85,1,1)")
    parser.add_argument("--no-shadow-rule", action="store_true",
                        help="do not recognise shadows (the ablation: shadows become obstacles)")
    parser.add_argument("--no-shadow-texture", action="store_true",
                        help="do not make obstacles of shadow pixels that lack the ground's texture "
                             "(smooth dark faces; docs/segmentation.md)")
    parser.add_argument("--colour-model", choices=("log_rgb", "hsi"), default="log_rgb",
                        help="ground colours as a log-RGB colour table (default) or the paper's HSI rule")
    parser.set_defaults(handler=run)


SIDECAR_FORMAT = "stereo-obstacles/segmentation"
"""``format`` of the JSON record written beside the labels (``LABELS.png.json``)."""


def _is_sidecar(path: Path) -> bool:
    """Whether ``path`` holds a record ``segment`` wrote (those written before it had a ``format``
    are known by their fields)."""
    from stereo_obstacles.atomic import json_object

    data = json_object(path)
    return data.get("format") == SIDECAR_FORMAT or {"version", "image", "reference", "fractions"} <= data.keys()


def _ground_check_record(check: GroundCheck | None) -> dict | None:
    """JSON record of the stereo ground check (None when not made)."""
    if check is None:
        return None
    plane = check.plane
    return {"plane_disparity_px": {"a": plane.a, "b": plane.b, "c": plane.c,
                                   "meaning": "d = a x + b y + c, x column and y row in pixels"},
            "patches": check.n_patches, "plane_inliers": plane.n_inliers, "plane_box_px": list(check.plane_box),
            "plane_fallback_reason": check.fallback_reason,
            "noise_variance_grey_levels_sq": check.noise_variance,
            "off_ground_fraction": float(check.off_ground.mean()),
            "above_horizon_fraction": float(check.above_horizon.mean())}


def run(args: argparse.Namespace) -> int:
    """Segment the image and write the outputs; returns the exit code."""
    import json

    import numpy as np

    from stereo_obstacles import __version__
    from stereo_obstacles.atomic import check_output_file, refuse_foreign_file, write_text_atomic
    from stereo_obstacles.fileio import (check_image_path, check_labels_path, read_image, to_uint8, write_image,
                                         write_labels)
    from stereo_obstacles.image_pairs import check_pair_of_files
    from stereo_obstacles.labels import Label, colorize_labels
    from stereo_obstacles.reference_area import DEFAULT_REFERENCE_AREA, ReferenceArea
    from stereo_obstacles.segmentation import SegmentationParameters, segment
    from stereo_obstacles.shadow_texture import ShadowTextureParameters
    from stereo_obstacles.synthetic.scene_files import refuse_scene_files

    inputs = (args.image, args.right)
    for target in (args.output, f"{args.output}.json", args.overlay):
        if target is not None:
            check_output_file(target, inputs)
            inputs += (target,)
    refuse_foreign_file(f"{args.output}.json", ours=_is_sidecar, what="segmentation record")
    refuse_scene_files(args.output, args.overlay)
    check_labels_path(args.output)                       # the formats too, before the first file is written
    if args.overlay:
        check_image_path(args.overlay)
    rgb = read_image(args.image, mode="color")
    right = None if args.right is None else read_image(args.right, mode="color")
    if right is not None:
        check_pair_of_files(rgb, right, args.image, f"--right {args.right}")
        rgb, right = to_uint8(rgb, right)            # 16-bit images by their significant bits, as detect does
    else:
        (rgb,) = to_uint8(rgb)
    reference = ReferenceArea.parse(args.reference) if args.reference else DEFAULT_REFERENCE_AREA
    texture = (ShadowTextureParameters(min_relative_texture=0.0) if args.no_shadow_texture
               else ShadowTextureParameters())
    params = SegmentationParameters(shadow_rule=not args.no_shadow_rule, colour_model=args.colour_model,
                                    shadow_texture=texture)
    result = segment(rgb, right=right, reference=reference, params=params)
    write_labels(args.output, result.labels)
    if args.overlay:
        blended = (0.55 * rgb + 0.45 * colorize_labels(result.labels)).astype(np.uint8)
        x0, y0, x1, y1 = result.reference.box_px
        blended[y0:y1, [x0, x1 - 1]] = 255
        blended[[y0, y1 - 1], x0:x1] = 255
        write_image(args.overlay, blended)
    sidecar = {"format": SIDECAR_FORMAT, "version": __version__, "image": str(args.image),
               "reference": result.reference.as_dict(),
               "shadow_rule": params.shadow_rule, "colour_model": params.colour_model,
               "right_image": None if args.right is None else str(args.right),
               "ground_check": _ground_check_record(result.ground_check),
               "shadow_texture": {"made": result.textureless_shadow is not None,
                                  "obstacle_fraction": (None if result.textureless_shadow is None
                                                        else float(result.textureless_shadow.mean()))},
               "fractions": {label.name.lower(): float(np.mean(result.labels == label))
                             for label in (Label.GROUND, Label.SHADOW, Label.OBSTACLE, Label.UNKNOWN)}}
    write_text_atomic(f"{args.output}.json", json.dumps(sidecar, indent=2) + "\n")
    print(f"wrote {args.output}: " + ", ".join(f"{name} {100 * value:.1f} %"
                                                for name, value in sidecar["fractions"].items()))
    return 0
