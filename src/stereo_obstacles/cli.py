"""The ``stereo-obstacles`` command: argparse sub-commands, logging set-up, error reporting.

Each sub-command lives in its own module under :mod:`stereo_obstacles.commands` and exposes
``register(subparsers)``, which adds its parser and sets ``handler`` to a function taking the
parsed arguments and returning an exit code. Those modules import heavy dependencies (NumPy,
OpenCV, numba) inside their handlers so that ``--help`` stays instant.

Errors the user can cause (:class:`~stereo_obstacles.errors.StereoObstaclesError`) are
printed as one line on stderr with exit code 1; an interrupt exits with 130 (also when it lands
inside a compiled kernel), a SIGTERM with 143 after the same clean-up (staged outputs removed);
an unexpected failure prints one line naming the bug report and exits with 3 (``-vv`` shows the
traceback).
"""

from __future__ import annotations

import argparse
import importlib
import logging
import os
import signal
import sys
import threading
from collections.abc import Sequence

from stereo_obstacles import __version__
from stereo_obstacles.interrupts import EXIT_INTERRUPTED, EXIT_TERMINATED, Terminated, interrupt_exit_code, is_interrupt

PROG = "stereo-obstacles"

COMMAND_MODULES: tuple[str, ...] = (
    "demo",
    "detect",
    "scene",
    "disparity",
    "segment",
    "evaluate_segmentation",
    "evaluate",
    "evaluate_detection",
    "video",
    "batch",
    "calibrate",
    "rectify",
)
"""Sub-command modules in the order ``--help`` lists them."""

EXIT_OK = 0
EXIT_ERROR = 1
EXIT_USAGE = 2
EXIT_INTERNAL = 3


class _OneLineParser(argparse.ArgumentParser):
    """A parser whose usage errors are one line (argparse prints the whole usage block first,
    nine lines for ``detect``); sub-command parsers are of this class too."""

    def error(self, message: str):
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    """The full argument parser with every sub-command registered."""
    parser = _OneLineParser(
        prog=PROG,
        description="Obstacles and their distances from a pair of colour stereo images.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    parser.add_argument("-v", "--verbose", action="count", default=0,
                        help="more log output (-v info, -vv debug with tracebacks)")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", title="commands")
    subparsers.required = True
    for name in COMMAND_MODULES:
        module = importlib.import_module(f"stereo_obstacles.commands.{name}")
        module.register(subparsers)
    return parser


def _configure_logging(verbosity: int) -> None:
    level = logging.WARNING if verbosity == 0 else logging.INFO if verbosity == 1 else logging.DEBUG
    logging.basicConfig(level=level, format=f"{PROG}: %(levelname)s: %(message)s", stream=sys.stderr)
    logging.captureWarnings(True)
    if verbosity == 0:
        # OpenCV's own "[ WARN:0@0.16] global grfmt_png.cpp:793 ..." lines would stand beside our one
        # error line (a truncated image); read when cv2 is first imported, which the handlers do
        os.environ.setdefault("OPENCV_LOG_LEVEL", "ERROR")


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__


def _terminate(signum, frame) -> None:
    raise Terminated


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line and return its exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    _configure_logging(args.verbose)
    in_main_thread = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, _terminate) if in_main_thread else None
    try:
        return _run(args)
    finally:
        if in_main_thread:
            signal.signal(signal.SIGTERM, previous)


def _run(args: argparse.Namespace) -> int:
    from stereo_obstacles.errors import StereoObstaclesError

    try:
        return int(args.handler(args) or EXIT_OK)
    except StereoObstaclesError as exc:
        if args.verbose >= 2:
            logging.getLogger(__name__).exception("details")
        print(f"{PROG}: error: {_one_line(exc)}", file=sys.stderr)
        return EXIT_ERROR
    except MemoryError:
        print(f"{PROG}: error: out of memory (try smaller images)", file=sys.stderr)
        return EXIT_ERROR
    except (KeyboardInterrupt, Exception) as exc:  # noqa: BLE001 - the last line of defence against tracebacks
        if is_interrupt(exc):
            code = interrupt_exit_code(exc)
            print(f"{PROG}: {'terminated' if code == EXIT_TERMINATED else 'interrupted'}", file=sys.stderr)
            return code
        if args.verbose >= 2:
            raise
        print(f"{PROG}: internal error: {type(exc).__name__}: {_one_line(exc)} "
              f"(this is a bug; rerun with -vv for the traceback)", file=sys.stderr)
        return EXIT_INTERNAL
