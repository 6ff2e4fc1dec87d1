"""``stereo-obstacles batch``: detect (or match) every stereo pair under a folder, in parallel, resumable."""

from __future__ import annotations

import argparse

from stereo_obstacles.commands._arguments import output_path
from stereo_obstacles.commands._calibration_options import CALIB_UNIT_HELP
from stereo_obstacles.commands.detect import add_detection_options

DESCRIPTION = """\
Run 'detect' (or 'disparity') on every stereo pair under INPUT_DIR: INPUT_DIR itself when it is
one dataset with its calibration, sub-folders of a known dataset layout (as 'evaluate' reads
them; KITTI folders give one pair per frame), <name>_left/<name>_right (or <name>_L/<name>_R)
images, or left/ and right/ folders of same-named images (folders without images, and reports of
this tool holding no pair, are left out with a warning). Each pair's outputs go to
OUT/<name>/, and a done.json written last marks it complete: a second run skips completed
pairs, and is refused when a pair was done with another task, calibration or option the task
uses. A failing pair is reported with its reason and the batch goes on. The summary
is written to OUT/batch_summary.json. Exit code 0 when every pair is done, 1 when some failed,
130 on Ctrl-C (pairs already started are finished first; a second Ctrl-C stops at once), 143 on
SIGTERM."""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``batch`` sub-command."""
    parser = subparsers.add_parser("batch", help="detect or match every pair under a folder, in parallel",
                                   description=DESCRIPTION)
    parser.add_argument("input_dir", metavar="INPUT_DIR", help="folder of stereo pairs")
    parser.add_argument("--out", required=True, type=output_path, metavar="DIR",
                        help="output folder (created if needed)")
    parser.add_argument("--task", choices=("detect", "disparity"), default="detect",
                        help="what to run on each pair (default detect)")
    parser.add_argument("--workers", type=int, default=None, metavar="N",
                        help="local worker processes (default: the number of CPUs; 1 runs in this process)")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="run on a Dask cluster, e.g. tcp://host:8786 (needs the [dask] extra; workers "
                             "must see the same paths)")
    parser.add_argument("--calib", metavar="FILE",
                        help="calibration file for every pair (default: each dataset folder's own, if any)")
    parser.add_argument("--calib-unit", choices=["m", "cm", "mm"],
                        help=CALIB_UNIT_HELP)
    add_detection_options(parser)
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Find the pairs, run them, print and write the summary."""
    import os
    import sys
    import time
    from pathlib import Path

    from stereo_obstacles.atomic import check_output_folder, json_object, refuse_foreign_file
    from stereo_obstacles.batch import (DONE_FILE, SUMMARY_FILE, SUMMARY_FORMAT, BatchJob, check_done_settings,
                                        find_pairs, finished_unreported, run_batch, write_summary)
    from stereo_obstacles.camera_calibration import read_camera_calibration
    from stereo_obstacles.commands._compile_notice import announce_compilation
    from stereo_obstacles.commands.detect import config_from_args
    from stereo_obstacles.errors import InvalidInputError, OutputError
    from stereo_obstacles.interrupts import EXIT_INTERRUPTED, StopRequest, interrupt_exit_code, is_interrupt
    from stereo_obstacles.progress import Progress

    workers = args.workers if args.workers is not None else (os.cpu_count() or 1)
    if workers < 1:
        raise InvalidInputError(f"--workers must be >= 1, got {workers}")
    config = config_from_args(args)
    out = Path(args.out)
    check_output_folder(out)
    refuse_foreign_file(out / SUMMARY_FILE, ours=lambda path: json_object(path).get("format") == SUMMARY_FORMAT,
                        what="batch summary")
    if out.resolve() == Path(args.input_dir).resolve():
        raise OutputError(f"--out {out} is the input folder: the pairs' outputs would replace their inputs")
    # read once, before any pair: a bad file is one error, a warning about it is shown once
    calibration = read_camera_calibration(args.calib, length_unit=args.calib_unit) if args.calib is not None else None
    pairs = find_pairs(args.input_dir, skip=out)
    jobs = [BatchJob(pair, str(out / pair.name), args.task, config, args.calib, calibration) for pair in pairs]
    settings = {"input_dir": str(args.input_dir), "task": args.task, "workers": None if args.scheduler else workers,
                "scheduler": args.scheduler, "calib": args.calib, "calib_unit": args.calib_unit,
                "config": config.to_dict()}
    done = [(Path(job.out_dir) / DONE_FILE).is_file() for job in jobs]
    pending = [job for job, was_done in zip(jobs, done) if not was_done]
    check_done_settings(job for job, was_done in zip(jobs, done) if was_done)
    announce_compilation()         # the workers compile on their first pair
    progress = Progress(len(jobs), label="pair")

    def report(outcome) -> None:
        if outcome.status == "failed":
            if progress.enabled:
                sys.stderr.write("\r\033[K")
            print(f"{outcome.name}: failed: {outcome.reason}", file=sys.stderr)
        progress.update(note=outcome.name)

    start = time.monotonic()
    outcomes: list = []
    interrupted = False
    exit_code = EXIT_INTERRUPTED           # when stopped by a Ctrl-C between pairs
    try:
        with StopRequest("the pairs already started") as stop:
            run_batch(jobs, workers=workers, scheduler=args.scheduler,
                      on_outcome=lambda o: (outcomes.append(o), report(o)), should_stop=lambda: stop.requested)
        interrupted = stop.requested
    except (KeyboardInterrupt, SystemError) as exc:
        if not is_interrupt(exc):
            raise
        interrupted = True
        exit_code = interrupt_exit_code(exc)
    finally:
        progress.close()
    outcomes += finished_unreported(pending, outcomes)      # pairs an interrupt did not wait for
    seconds = time.monotonic() - start
    summary = write_summary(out, outcomes, seconds=seconds, interrupted=interrupted, settings=settings)
    counts = {s: sum(o.status == s for o in outcomes) for s in ("done", "skipped", "failed")}
    print(f"{len(jobs)} pairs: {counts['done']} done, {counts['skipped']} skipped (done before), "
          f"{counts['failed']} failed{', interrupted' if interrupted else ''} in {seconds:.1f} s "
          f"({counts['done'] / seconds if seconds > 0 else 0:.2f} pairs/s); summary {summary}")
    if interrupted:
        return exit_code
    return 1 if counts["failed"] else 0
