"""``stereo-obstacles video``: obstacles in every frame of a stereo stream, tracked across frames."""

from __future__ import annotations

import argparse

from stereo_obstacles.commands._arguments import output_path
from stereo_obstacles.commands._calibration_options import add_calibration_options
from stereo_obstacles.commands.detect import add_detection_options

DESCRIPTION = """\
Detect obstacles in every frame of a stereo stream and track them: the same obstacle keeps its
id, its distance is smoothed, and obstacles coming nearer are flagged with their time to
contact. The frames must be rectified, unless --calib describes the raw cameras (as 'calibrate'
writes them): then every frame is rectified first. SOURCE is one side-by-side video (left view
in the left half), two video files, two folders or glob patterns of images (in path order,
paired by name when both sides hold the same names, else by order; refused when they share at
least half their names but not all), or two camera device indices. With --jsonl every frame is one line of JSON, written and synced line by line:
a run stopped by Ctrl-C (it finishes the current frame, closes every output and exits with 130;
a second Ctrl-C stops at once), by SIGTERM (once the frame being written is, exit 143) or killed leaves only complete
lines (the first line is a header, the last one, after a clean, Ctrl-C or SIGTERM stop, a
summary)."""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``video`` sub-command."""
    parser = subparsers.add_parser("video", help="obstacles in a stereo video, image sequences or live cameras",
                                   description=DESCRIPTION)
    parser.add_argument("source", nargs="+", metavar="SOURCE",
                        help="side-by-side video | LEFT_VIDEO RIGHT_VIDEO | LEFT_IMAGES RIGHT_IMAGES | CAM CAM")
    parser.add_argument("--kind", choices=("auto", "videos", "images", "side-by-side", "cameras"), default="auto",
                        help="what SOURCE is (default: guessed from the arguments)")
    parser.add_argument("--fps", type=float, default=30.0,
                        help="frame rate of image sequences, for timestamps (default 30)")
    parser.add_argument("--jsonl", metavar="FILE", type=output_path, help="write one JSON line per frame ('-' for stdout)")
    parser.add_argument("--video-out", metavar="FILE", help="write an annotated video (mp4v)")
    parser.add_argument("--frames-out", metavar="DIR",
                        help="write every frame's full detection outputs (as 'detect --out') to DIR/<frame>/")
    parser.add_argument("--max-frames", type=int, metavar="N", help="stop after N frames")
    parser.add_argument("--in-flight", type=int, default=None, metavar="N",
                        help="frames detected at once (default 3: more frames per second on two cores; "
                             "1: each frame waits for the one before, the lowest latency)")
    seeds = parser.add_argument_group("temporal seeds")
    seeds.add_argument("--temporal-seeds", action=argparse.BooleanOptionalAction, default=True,
                       help="seed each frame's matching from the previous frame's matches (default on)")
    seeds.add_argument("--seed-step", type=int, default=None, metavar="PX",
                       help="grid step of the temporal seeds, pixels (default 8)")
    seeds.add_argument("--refresh-every", type=int, default=None, metavar="N",
                       help="use edge seeds every N frames (default 30; 0: only when too few seeds)")
    seeds.add_argument("--refine-frames", type=int, default=None, metavar="N",
                       help="after each grown frame, match N frames by refining its disparity only (default 1; "
                            "0: every frame grows)")
    seeds.add_argument("--forward-speed", type=float, default=None, metavar="M",
                       help="expected forward motion per frame in metres, to move the seeds (needs a calibration; "
                            "default 0)")
    add_calibration_options(parser)
    add_detection_options(parser)
    parser.set_defaults(handler=run)


def _rectified(rectification, frame):
    """``frame`` (a :class:`~stereo_obstacles.streams.StereoFrame`) with its images rectified."""
    from dataclasses import replace

    from stereo_obstacles.errors import ImageMismatchError

    try:
        left, right = rectification.apply(frame.left, frame.right)
    except ImageMismatchError as exc:
        raise ImageMismatchError(f"frame {frame.index} ({frame.name}): {exc}") from exc
    return replace(frame, left=left, right=right)


def _frame_line(record: dict, calibrated: bool) -> str:
    """One short line per frame for the terminal when no --jsonl is written."""
    parts = []
    for o in record["obstacles"]:
        if calibrated and o["distance_m"] is not None:
            text = f"#{o['track_id']} {o['distance_m']:.2f} m"
            if o["approaching"]:
                text += f" approaching ({o['time_to_contact_s']:.1f} s)"
        else:
            text = f"#{o['track_id']} d={o['disparity_px']:.1f} px"
        parts.append(text)
    return f"frame {record['frame']} t={record['timestamp_s']:.2f} s: " + ("; ".join(parts) or "no obstacles")


class _VideoOut:
    """An mp4v video written beside its final name and renamed into place when closed.

    Frames of an odd width or height get one black column or row more (the mp4v encoder
    takes even sizes only and would crop the last row or column)."""

    def __init__(self, path: str, fps: float, size: tuple[int, int]) -> None:
        from pathlib import Path

        import cv2

        from stereo_obstacles.atomic import discard_temporary, temporary_beside
        from stereo_obstacles.errors import OutputError

        self.final = Path(path)
        self.tmp = temporary_beside(self.final, suffix=self.final.suffix or ".mp4")
        self.padding = (size[1] % 2, size[0] % 2)     # rows, columns
        even = (size[0] + self.padding[1], size[1] + self.padding[0])
        self.writer = cv2.VideoWriter(str(self.tmp), cv2.VideoWriter_fourcc(*"mp4v"), fps, even)
        if not self.writer.isOpened():
            discard_temporary(self.tmp)
            raise OutputError(f"cannot write video {self.final} (OpenCV has no mp4v writer for it)")
        self.frames = 0

    def write(self, rgb) -> None:
        import cv2

        bgr = cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR)
        if any(self.padding):
            bgr = cv2.copyMakeBorder(bgr, 0, self.padding[0], 0, self.padding[1], cv2.BORDER_CONSTANT, value=0)
        self.writer.write(bgr)
        self.frames += 1

    def close(self) -> None:
        """Finish the file; keep it when it holds at least one frame."""
        from stereo_obstacles.atomic import discard_temporary, move_into_place

        self.writer.release()
        if self.frames:
            move_into_place(self.tmp, self.final)
        else:
            discard_temporary(self.tmp)


def _pattern_matches(sources) -> tuple[str, ...]:
    """The files the glob patterns among ``sources`` name: an output must not replace one of those
    images (folders are refused as a whole by the output checks)."""
    import glob

    return tuple(match for source in sources if glob.has_magic(source) for match in glob.glob(source))


def _refuse_pattern_outputs(sources, target: str) -> None:
    """Raise :class:`OutputError` when the output ``target`` would match one of the glob patterns
    among ``sources`` (the next run would read it as a frame), even before it exists."""
    import fnmatch
    import glob
    import os

    from stereo_obstacles.errors import OutputError

    for pattern in (source for source in sources if glob.has_magic(source)):
        if fnmatch.fnmatchcase(os.path.abspath(target), os.path.abspath(pattern)):
            raise OutputError(f"{target} matches the source pattern {pattern}: a later run would read it as a "
                              f"frame; write it elsewhere")


def _temporal_parameters(args: argparse.Namespace):
    """The :class:`~stereo_obstacles.temporal_seeds.TemporalSeedParameters` the options give, the
    unset ones at their defaults; ``None`` with ``--no-temporal-seeds`` (options of the seeds given
    with it are warned of: they do nothing then)."""
    import logging

    from stereo_obstacles.temporal_seeds import TemporalSeedParameters

    given = {"step_px": args.seed_step, "refresh_every": args.refresh_every,
             "forward_m_per_frame": args.forward_speed, "refine_frames": args.refine_frames}
    given = {name: value for name, value in given.items() if value is not None}
    if not args.temporal_seeds:
        if given:
            options = {"step_px": "--seed-step", "refresh_every": "--refresh-every",
                       "forward_m_per_frame": "--forward-speed", "refine_frames": "--refine-frames"}
            logging.getLogger(__name__).warning("%s do%s nothing with --no-temporal-seeds",
                                                ", ".join(options[name] for name in given),
                                                "es" if len(given) == 1 else "")
        return None
    return TemporalSeedParameters(**given)


def _end_record(frames: int, interrupted: bool, elapsed_s: float, *, error: str | None = None) -> dict:
    """The JSON lines' last record: frames written, whether a Ctrl-C or SIGTERM stopped the run,
    its time; ``error``: the one-line error that ended it (the key only then)."""
    record = {"type": "end", "frames": frames, "interrupted": interrupted, "seconds": round(elapsed_s, 3),
              "frames_per_second": round(frames / elapsed_s, 3) if elapsed_s > 0 else None}
    return record if error is None else {**record, "error": error}


def run(args: argparse.Namespace) -> int:
    """Open the source, detect and track frame by frame, write what was asked; 130 on Ctrl-C, 143 on
    SIGTERM."""
    import itertools
    import sys
    import time
    from contextlib import ExitStack
    from dataclasses import replace
    from pathlib import Path

    from stereo_obstacles.allocator import keep_freed_memory
    from stereo_obstacles.atomic import check_output_file, check_output_folder
    from stereo_obstacles.commands._calibration_options import calibration_and_rectification
    from stereo_obstacles.commands._compile_notice import announce_compilation
    from stereo_obstacles.commands._frame_reports import say_earlier_reports_removed
    from stereo_obstacles.commands._repeated_warnings import each_warning_once, repeats_note
    from stereo_obstacles.commands.detect import config_from_args
    from stereo_obstacles.errors import InputFileError, InvalidInputError, StereoObstaclesError
    from stereo_obstacles.interrupts import (EXIT_INTERRUPTED, StopRequest, TerminationDeferred, interrupt_exit_code,
                                             is_interrupt)
    from stereo_obstacles.jsonl import JsonLinesWriter
    from stereo_obstacles.progress import Progress
    from stereo_obstacles.pipeline import pair_rectification_check
    from stereo_obstacles.rectification_check import refuse_swapped, refusing_swapped_pairs
    from stereo_obstacles.report import write_detection_outputs
    from stereo_obstacles.stream_detection import (IN_FLIGHT, annotate_frame, detect_stream, frame_record,
                                                   header_record)
    from stereo_obstacles.streams import IMAGE_EXTENSIONS, open_source
    from stereo_obstacles.tracking import TrackingParameters

    if args.max_frames is not None and args.max_frames < 1:
        raise InvalidInputError(f"--max-frames must be >= 1, got {args.max_frames}")
    in_flight = IN_FLIGHT if args.in_flight is None else args.in_flight
    if in_flight < 1:
        raise InvalidInputError(f"--in-flight must be >= 1, got {in_flight}")
    temporal = _temporal_parameters(args)
    config = config_from_args(args)
    if args.video_out and Path(args.video_out).suffix.lower() in IMAGE_EXTENSIONS:
        raise InvalidInputError(f"--video-out {args.video_out} names an image; give a video file name such as "
                                f"annotated.mp4")
    written = tuple(args.source) + _pattern_matches(args.source) + ((args.calib,) if args.calib else ())
    for target in (args.video_out, None if args.jsonl == "-" else args.jsonl):
        if target:
            check_output_file(target, inputs=written, input_folders=args.source)   # nor the other output
            _refuse_pattern_outputs(args.source, target)
            written += (target,)
    if args.frames_out:
        check_output_folder(args.frames_out, inputs=written)
    keep_freed_memory()  # a frame reuses the previous frames' arrays instead of faulting in fresh pages
    announce_compilation()
    tracking = TrackingParameters()
    interrupted = False
    exit_code = EXIT_INTERRUPTED           # when stopped by a Ctrl-C between frames
    count = 0
    start = time.monotonic()
    with ExitStack() as stack:
        repeats = stack.enter_context(each_warning_once(not args.verbose))
        source = stack.enter_context(open_source(args.source, kind=args.kind, fps=args.fps))
        frames = iter(source)
        first = next(frames, None)
        if first is None:
            raise InputFileError(f"{source.description}: no frames")
        height, width = first.left.shape[:2]
        calibration, rectification = calibration_and_rectification(args, width, height)
        rectified_by = None
        if rectification is not None:         # the raw cameras' calibration: every frame is rectified first
            first, frames = _rectified(rectification, first), (_rectified(rectification, f) for f in frames)
            rectified_by = rectification.report(args.calib)
        if temporal is not None and temporal.forward_m_per_frame and calibration is None:
            raise InvalidInputError("--forward-speed needs a calibration (--calib, or --focal and --baseline): "
                                    "without one the motion cannot be turned into disparities")
        with refusing_swapped_pairs():
            first_check = pair_rectification_check(first.left, first.right)
        refuse_swapped(first_check)     # before any output is written
        first_checked = {**first_check.to_dict(), "frame": first.index}      # the rig does not change
        checked = replace(config, check_rectification=False)                # done: the rig does not change
        video = None
        if args.video_out:              # first: a writer OpenCV refuses must not cost an earlier --jsonl file
            video = _VideoOut(args.video_out, source.fps, (width, height))
            stack.callback(video.close)
        jsonl = None
        if args.jsonl:
            jsonl = stack.enter_context(JsonLinesWriter("/dev/stdout" if args.jsonl == "-" else args.jsonl,
                                                        sync=args.jsonl != "-"))
            jsonl.write(header_record(source=source.description, calibration=calibration, config=config,
                                      temporal=temporal, tracking=tracking, rectification=rectified_by))
        total = None if source.is_live else source.total_frames
        if total is not None and args.max_frames is not None:
            total = min(total, args.max_frames)
        progress = Progress(total, label="frame")
        stack.callback(progress.close)
        stream = detect_stream(itertools.chain([first], frames), calibration, config=checked, temporal=temporal,
                               tracking=tracking, in_flight=in_flight)
        stop = stack.enter_context(StopRequest("the current frame"))
        reported: set[str] = set()
        try:
            for detection in stream:
                # a SIGTERM waits for the frame's outputs: all of them or none hold the frame (an error
                # in the report, the slowest, leaves it out of the others too)
                with TerminationDeferred():
                    if args.frames_out:
                        result = detection.result
                        write_detection_outputs(Path(args.frames_out) / detection.frame.name,
                                                left=detection.frame.left, labels=result.segmentation.labels,
                                                disparity=result.disparity, depth_m=result.depth_m,
                                                obstacle_list=result.obstacles, calibration=calibration,
                                                config=config.to_dict(), timings=result.timings_s,
                                                inputs={"source": source.description, "frame": detection.frame.index,
                                                        "rectification": rectified_by,
                                                        "rectification_check": first_checked})
                    if video is not None:
                        video.write(annotate_frame(detection))
                    record = frame_record(detection)
                    if jsonl is not None:
                        jsonl.write(record)
                    elif not progress.enabled:
                        print(_frame_line(record, calibration is not None), flush=True)
                    count += 1
                    reported.add(detection.frame.name)
                near = [t for t in detection.tracks if t.approaching and t.obstacle is not None]
                progress.update(note=f"approaching #{near[0].track_id}" if near else "")
                if stop.requested:
                    interrupted = True
                    break
                if args.max_frames is not None and count >= args.max_frames:
                    break
        except (KeyboardInterrupt, SystemError) as exc:
            if not is_interrupt(exc):
                raise
            interrupted = True
            exit_code = interrupt_exit_code(exc)
        except StereoObstaclesError as exc:          # a bad frame mid-stream: the lines say where and why it stopped
            if jsonl is not None:
                jsonl.write(_end_record(count, False, time.monotonic() - start, error=" ".join(str(exc).split())))
            raise
        finally:
            stream.close()
        elapsed = time.monotonic() - start
        if jsonl is not None:
            jsonl.write(_end_record(count, interrupted, elapsed))
        if args.frames_out and not interrupted:
            say_earlier_reports_removed(args.frames_out, reported, source.description)
    print(f"{'interrupted after' if interrupted else 'processed'} {count} frame{'s' if count != 1 else ''} "
          f"in {elapsed:.1f} s ({count / elapsed if elapsed > 0 else 0:.2f} frames/s)"
          f"{'; ' + repeats_note(repeats()) if repeats() else ''}",
          file=sys.stderr)
    return exit_code if interrupted else 0
