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


def frame_report_source(folder) -> str | None:
    """The source (its description) of the report ``video`` wrote for a frame into ``folder``,
    whose ``run.inputs`` name a source and a frame as no ``detect`` report's do; else ``None``."""
    if not holds_a_report(folder):
        return None
    try:
        inputs = json.loads((Path(folder) / "obstacles.json").read_text(encoding="utf-8"))["run"]["inputs"]
    except (OSError, ValueError, KeyError, TypeError):
        return None
    if not (isinstance(inputs, dict) and "frame" in inputs and isinstance(inputs.get("source"), str)):
        return None
    return inputs["source"]


def remove_earlier_reports(folder, keep, source: str) -> tuple[int, int]:
    """Remove the frame reports of an earlier run over ``source`` in the sub-folders of ``folder``
    not named in ``keep`` (the frames of a longer run, which would pass for this run's). Returns
    how many went, and how many frame reports of another source (or of this one named otherwise,
    ``./walk`` for ``walk``) stay. Anything else there (a ``detect`` report) stays too."""
    if not Path(folder).is_dir():
        return 0, 0
    others = [(frame, frame_report_source(frame)) for frame in Path(folder).iterdir()   # not a hidden staging folder
              if frame.name not in keep and not frame.name.startswith(".") and frame.is_dir()
              and not frame.is_symlink()]
    earlier = [frame for frame, of in others if of == source]
    for frame in earlier:
        remove_file_set(frame, OUTPUT_FILES, what="the earlier frame report")     # obstacles.json first
    return len(earlier), sum(1 for _, of in others if of is not None and of != source)


def say_earlier_reports_removed(folder, keep, source: str) -> None:
    """:func:`remove_earlier_reports`, saying on stderr how many went and warning of the frame
    reports of other sources that stay; one that cannot be removed is a warning too: every frame
    of this run is written by then."""
    try:
        removed, foreign = remove_earlier_reports(folder, keep, source)
    except OutputError as exc:
        logging.getLogger(__name__).warning("%s; the other frames of an earlier run stay in %s", exc, folder)
        return
    if removed:
        print(f"removed {removed} frame report{'s' if removed != 1 else ''} of an earlier run over this source "
              f"from {folder}", file=sys.stderr)
    if foreign:
        logging.getLogger(__name__).warning(
            "%s also holds %d frame report%s of another source (or of this one named otherwise): they stay beside "
            "this run's", folder, foreign, "s" if foreign != 1 else "")
