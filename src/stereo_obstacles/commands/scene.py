"""``stereo-obstacles scene``: render a synthetic stereo scene with exact ground truth."""

from __future__ import annotations

import argparse

from stereo_obstacles.commands._arguments import jpeg_quality, output_path

GROUNDS = ("pavement", "grass", "tiles", "asphalt")
DEFAULT_SPEED_M = 0.05
"""Forward motion of the rig per frame of ``--frames``, metres (a walk at 1.5 m/s, 30 frames/s)."""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``scene`` sub-command."""
    parser = subparsers.add_parser(
        "scene", help="render a synthetic stereo pair with exact ground truth",
        description="Render a synthetic stereo scene: left/right images, disparity, depth, labels, "
                    "obstacle list and calibration. Seed 0 is the built-in default scene; other "
                    "seeds give random scenes.")
    parser.add_argument("--out", required=True, type=output_path, metavar="DIR",
                        help="output folder (created if needed)")
    parser.add_argument("--seed", type=int, default=0, metavar="N",
                        help="0 = the default scene (default), other values = a random scene")
    parser.add_argument("--size", default="640x480", metavar="WxH", help="image size (default 640x480)")
    parser.add_argument("--ground", choices=GROUNDS, default=None,
                        help="ground material (default: pavement for seed 0, random otherwise)")
    parser.add_argument("--noise", type=float, default=0.0, metavar="SIGMA",
                        help="Gaussian sensor noise, grey levels (default 0)")
    parser.add_argument("--gain-diff", type=float, default=0.0, metavar="G",
                        help="right camera gain relative to the left minus 1 (0.1 = 10%% brighter)")
    parser.add_argument("--brightness-diff", type=float, default=0.0, metavar="B",
                        help="brightness offset of the right image, grey levels")
    parser.add_argument("--right-rotation-deg", type=float, nargs=3, default=(0.0, 0.0, 0.0),
                        metavar=("RX", "RY", "RZ"),
                        help="rotation of the right camera about its X, Y, Z axes, degrees (an unrectified pair; "
                             "its true calibration is written to camera_pair.json, for rectify --calib)")
    parser.add_argument("--right-offset-px", type=float, default=0.0, metavar="PX",
                        help="vertical shift of the right image, pixels (camera_pair.json, as above)")
    parser.add_argument("--jpeg-quality", type=jpeg_quality, default=None, metavar="Q",
                        help="deliver both images JPEG-compressed at quality Q, 1..100 (as a webcam in MJPG "
                             "mode; written as PNG after the round trip)")
    parser.add_argument("--no-shadows", action="store_true", help="render without cast shadows")
    parser.add_argument("--supersample", type=int, default=1, metavar="S",
                        help="S x S rays per pixel (1..4, default 1)")
    parser.add_argument("--sun-azimuth-deg", type=float, default=None, metavar="DEG",
                        help="direction the sunlight comes from: 0 ahead, 90 right, 180 behind")
    parser.add_argument("--sun-elevation-deg", type=float, default=None, metavar="DEG",
                        help="sun height above the horizon, degrees")
    parser.add_argument("--frames", type=int, default=1, metavar="N",
                        help="render N frames with the rig walking forward (folders frame_0000, ...; the default 1 "
                             "writes the one scene into OUT itself)")
    parser.add_argument("--speed", type=float, default=None, metavar="M",
                        help=f"forward motion per frame in metres, with --frames (default {DEFAULT_SPEED_M})")
    parser.set_defaults(handler=run)


def _check_frame_folders(folder, names) -> None:
    """Raise :class:`~stereo_obstacles.errors.OutputError` when a frame folder about to be
    written already exists as something this command did not write (a link, a file, another
    tool's folder): the frame's files would go into it, or through it elsewhere. A frame whose
    files a move cut short left there is this command's (:func:`~stereo_obstacles.atomic.moved_in_files`)."""
    from pathlib import Path

    from stereo_obstacles.atomic import moved_in_files
    from stereo_obstacles.errors import OutputError
    from stereo_obstacles.synthetic.scene_files import SCENE_FILES, holds_a_scene

    vouched = None
    for name in names:
        frame = Path(folder) / name
        if frame.is_symlink() or (frame.exists() and not frame.is_dir()):
            raise OutputError(f"{frame} exists and is not a frame this command wrote; choose another --out")
        if not frame.exists() or holds_a_scene(frame):
            continue
        vouched = moved_in_files(folder, "scene") if vouched is None else vouched
        present = [file for file in ("scene.json",) + SCENE_FILES if (frame / file).exists()]
        theirs = [file for file in present if f"{name}/{file}" not in vouched]
        if theirs:
            raise OutputError(f"{frame} holds {', '.join(theirs)} but is not a frame this command wrote; choose "
                              f"another --out")
        if not present and any(frame.iterdir()):     # another tool's folder; a cut-short frame may hold notes too
            raise OutputError(f"{frame} exists and is not a frame this command wrote; choose another --out")


def _remove_frames(folder, keep) -> None:
    """Remove the scene files of the ``frame_*`` scene folders of ``folder`` not named in ``keep``
    (frames of an earlier sequence, which the dataset reader would take for this one's), and each
    such folder when nothing else is left in it, saying on stderr how many went; anything else
    there is the user's and stays."""
    import sys
    from pathlib import Path

    from stereo_obstacles.atomic import remove_file_set
    from stereo_obstacles.synthetic.scene_files import SCENE_FILES, holds_a_scene

    earlier = sorted(frame for frame in Path(folder).glob("frame_*")
                     if frame.name not in keep and not frame.is_symlink() and holds_a_scene(frame))
    for frame in earlier:
        remove_file_set(frame, ("scene.json",) + SCENE_FILES, what="the earlier frame")
    if earlier:
        print(f"removed {len(earlier)} frame{'s' if len(earlier) != 1 else ''} of an earlier sequence from {folder} "
              f"({earlier[0].name}{'' if len(earlier) == 1 else f'..{earlier[-1].name}'})", file=sys.stderr)


def _rectification_hint(options, calibration_file) -> None:
    """Say how to rectify a render whose right camera is off its rectified pose."""
    if not options.right_error.is_zero:
        print(f"the right camera is off its rectified pose: rectify the pair with --calib {calibration_file} "
              f"(stereo-obstacles rectify) before detecting")


def run(args: argparse.Namespace) -> int:
    """Render the scene and write its folder."""
    from dataclasses import replace
    from pathlib import Path

    from stereo_obstacles.atomic import staged_directory
    from stereo_obstacles.errors import InvalidInputError
    from stereo_obstacles.synthetic import (Lighting, RenderOptions, RightCameraError, default_scene,
                                            random_scene, render_pair, render_sequence, write_scene_folder)
    from stereo_obstacles.synthetic.scene_files import SCENE_FILES, check_scene_folder, holds_a_scene, scene_file_names

    from stereo_obstacles.commands._arguments import image_size

    width, height = image_size(args.size)
    if not -0.75 <= args.gain_diff <= 3.0:                # NaN too; the renderer's gain range [0.25, 4]
        raise InvalidInputError(f"--gain-diff must be in [-0.75, 3] (the right camera's gain is 1 + G), got "
                                f"{args.gain_diff}")
    if args.seed < 0:
        raise InvalidInputError(f"--seed must be >= 0, got {args.seed}")
    if args.seed == 0:
        scene = default_scene(width, height, ground=args.ground or "pavement")
        if args.sun_azimuth_deg is not None or args.sun_elevation_deg is not None:
            light = scene.lighting
            scene = replace(scene, lighting=Lighting(
                light.sun_azimuth_deg if args.sun_azimuth_deg is None else args.sun_azimuth_deg,
                light.sun_elevation_deg if args.sun_elevation_deg is None else args.sun_elevation_deg))
    else:
        scene = random_scene(args.seed, width_px=width, height_px=height, ground=args.ground,
                             sun_azimuth_deg=args.sun_azimuth_deg, sun_elevation_deg=args.sun_elevation_deg)
    options = RenderOptions(
        supersample=args.supersample, shadows=not args.no_shadows, noise_sigma=args.noise,
        right_gain=1.0 + args.gain_diff, right_bias=args.brightness_diff,
        right_error=RightCameraError(tuple(args.right_rotation_deg), args.right_offset_px),
        jpeg_quality=args.jpeg_quality)
    out = Path(args.out)
    if args.frames == 1:
        if args.speed is not None:
            raise InvalidInputError("--speed moves the rig between frames: give --frames N (N >= 2) too")
        check_scene_folder(out)                         # before the render
        write_scene_folder(out, render_pair(scene, options))
        _remove_frames(out, keep=())                    # a sequence written there before
        print(f"wrote scene (seed {scene.seed}, {width}x{height}) to {out}")
        _rectification_hint(options, out / "camera_pair.json")
        return 0
    names = [f"frame_{k:04d}" for k in range(args.frames)]
    _check_frame_folders(out, names)
    frames = render_sequence(scene, args.frames, DEFAULT_SPEED_M if args.speed is None else args.speed, options)
    stale = SCENE_FILES if holds_a_scene(out) else ()          # a single scene written there before goes,
    stale += tuple(f"{name}/{file}" for name in names            # and what this render does not write
                   for file in SCENE_FILES if file not in scene_file_names(options))
    # each frame's scene.json last: a move cut short leaves no frame that passes for a whole scene
    with staged_directory(out, last=tuple(f"{name}/scene.json" for name in names), stale=stale, kind="scene") as stage:
        for name, pair in zip(names, frames):
            write_scene_folder(stage / name, pair)
    _remove_frames(out, keep=names)                              # and the frames of a longer sequence
    print(f"wrote {args.frames} frames (seed {scene.seed}, {width}x{height}) to {out}/frame_*")
    _rectification_hint(options, out / names[0] / "camera_pair.json")     # one rig: every frame's file is the same
    return 0
