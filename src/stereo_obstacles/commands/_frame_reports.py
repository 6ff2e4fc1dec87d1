"""The per-frame reports ``video --frames-out`` writes: which sub-folders hold an earlier run's
frames over the same source, and their removal once a run has written its own."""

from __future__ import annotations

import json
import logging
import sys
from pathlib import Path

from stereo_obstacles.atomic import remove_file_set
from stereo_obstacles.errors import OutputError
from stereo_obstacles.report import OUTPUT_FILES, holds_a_report


def is_frame_report_of(folder, source: str) -> bool:
    """Whether ``folder`` holds the report ``video`` wrote for a frame of ``source`` (its
    description): ``run.inputs`` names that source and a frame, as no ``detect`` report does."""
    if not holds_a_report(folder):
        return False
    try:
        inputs = json.loads((Path(folder) / "obstacles.json").read_text(encoding="utf-8"))["run"]["inputs"]
    except (OSError, ValueError, KeyError, TypeError):
        return False
    return isinstance(inputs, dict) and "frame" in inputs and inputs.get("source") == source


def remove_earlier_reports(folder, keep, source: str) -> int:
    """Remove the frame reports of an earlier run over ``source`` in the sub-folders of ``folder``
    not named in ``keep`` (the frames of a longer run, which would pass for this run's); return how
    many. Anything else there (a ``detect`` report, another source's frames) stays."""
    if not Path(folder).is_dir():
        return 0
    earlier = [frame for frame in Path(folder).iterdir() if frame.name not in keep and frame.is_dir()
               and not frame.is_symlink() and is_frame_report_of(frame, source)]
    for frame in earlier:
        remove_file_set(frame, OUTPUT_FILES, what="the earlier frame report")     # obstacles.json first
    return len(earlier)


def say_earlier_reports_removed(folder, keep, source: str) -> None:
    """:func:`remove_earlier_reports`, saying on stderr how many went; one that cannot be removed
    is a warning: every frame of this run is written by then."""
    try:
        removed = remove_earlier_reports(folder, keep, source)
    except OutputError as exc:
        logging.getLogger(__name__).warning("%s; the other frames of an earlier run stay in %s", exc, folder)
        return
    if removed:
        print(f"removed {removed} frame report{'s' if removed != 1 else ''} of an earlier run over this source "
              f"from {folder}", file=sys.stderr)
