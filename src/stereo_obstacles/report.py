"""Everything a detection leaves behind: data files, pictures and an HTML report that shows them.

:func:`write_detection_outputs` writes one folder, all or nothing (files are staged in a
hidden folder and moved in only when every one is written):

==========================  ==================================================================
``obstacles.json``          the obstacles, see :mod:`stereo_obstacles.obstacle_json`
``disparity.pfm``           disparity in pixels (Middlebury PFM, ``+inf`` = none)
``depth.npy``               depth in metres, float32, NaN = unknown (with a calibration only)
``labels.png``              the phase-1 labels as raw ``uint8`` values (:class:`~stereo_obstacles.labels.Label`)
``points.ply``              coloured 3-D points of every pixel with depth (with a calibration only)
``obstacles.png``           the left image with obstacle boxes and distances
``disparity_picture.png``   disparity in turbo with a colour bar
``depth_picture.png``       depth in magma with a colour bar (with a calibration only)
``labels_picture.png``      the labels in colour with a legend
``scan_picture.png``        the free range per direction, seen from above (with a calibration only)
``index.html``              all of the above on one page, with the tables, timings and configuration
==========================  ==================================================================

:func:`format_obstacle_table` gives the plain-text table a terminal shows.
"""

from __future__ import annotations

import html
import json
import logging
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from stereo_obstacles import __version__
from stereo_obstacles.atomic import moved_in_files, refuse_foreign_files, staged_directory, write_text_atomic
from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.depth import points_from_depth
from stereo_obstacles.errors import InvalidInputError, OutputError
from stereo_obstacles.json_documents import is_document_of
from stereo_obstacles.fileio import to_uint8, write_depth, write_image, write_labels, write_pfm
from stereo_obstacles.labels import SEGMENTATION_LABELS
from stereo_obstacles.obstacle_json import (OBSTACLES_FORMAT, obstacles_to_dict, rectified_from_images, units_note,
                                            write_obstacles_json)
from stereo_obstacles.obstacles import Obstacle, ObstacleList
from stereo_obstacles.pictures import (
    depth_picture, describe_detection, disparity_picture, draw_obstacles, labels_picture, obstacle_colour, scan_picture)
from stereo_obstacles.point_cloud import write_ply

logger = logging.getLogger(__name__)

PICTURE_TITLES = {
    "obstacles.png": "Obstacles over the left image",
    "disparity_picture.png": "Disparity (pixels)",
    "depth_picture.png": "Depth (metres)",
    "labels_picture.png": ("Phase-1 labels by colour (ground, shadow, obstacle); with a calibration, ground-coloured "
                           "things standing above the ground plane become obstacles from the disparity"),
    "scan_picture.png": ("Free range per direction, seen from above: how far each sector of bearing is free before "
                         "its nearest obstacle (obstacles.json, \"scan\")"),
}
DATA_DESCRIPTIONS = {
    "obstacles.json": "obstacles, units, camera frame and calibration (JSON)",
    "disparity.pfm": "disparity in pixels (PFM, +inf = none)",
    "depth.npy": "depth in metres (NumPy float32, NaN = unknown)",
    "labels.png": "phase-1 labels as raw uint8 values (" + ", ".join(f"{v.value} {v.name.lower()}"
                                                                      for v in SEGMENTATION_LABELS) + ")",
    "points.ply": "coloured point cloud, metres, left camera frame (binary PLY)",
}


def _number(value: float | None, digits: int) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def _table(obstacle_list: ObstacleList, calibrated: bool) -> tuple[list[str], list[list[str]]]:
    """Header and rows of the obstacle table, nearest first."""
    def box(o: Obstacle) -> str:
        return ",".join(str(v) for v in o.box_px)

    if calibrated:
        header = ["#", "distance [m]", "X [m]", "width [m]", "height [m]", "top above ground [m]",
                  "disparity [px]", "box x0,y0,x1,y1 [px]", "pixels", "confidence"]
        rows = [[str(o.id), _number(o.distance_m, 2), _number(o.centre_m[0] if o.centre_m else None, 2),
                 _number(o.width_m, 2), _number(o.height_m, 2), _number(o.height_above_ground_m, 2),
                 _number(o.disparity_px, 1), box(o), str(o.pixel_count), _number(o.confidence, 2)]
                for o in obstacle_list.obstacles]
    else:
        header = ["#", "disparity [px]", "box x0,y0,x1,y1 [px]", "pixels", "confidence"]
        rows = [[str(o.id), _number(o.disparity_px, 1), box(o), str(o.pixel_count), _number(o.confidence, 2)]
                for o in obstacle_list.obstacles]
    return header, rows


def _corridor_sentence(obstacle_list: ObstacleList) -> str | None:
    corridor = obstacle_list.corridor
    if corridor is None:
        return None
    if corridor.nearest_obstacle_id is None:
        return (f"Corridor {corridor.width_m:g} m wide straight ahead: no obstacle found in it "
                f"(free beyond the measured range is unknown).")
    return (f"Corridor {corridor.width_m:g} m wide straight ahead: nearest obstacle #{corridor.nearest_obstacle_id}, "
            f"free for {corridor.free_distance_m:.2f} m.")


MAX_REJECTED_LINES = 5
"""The terminal table lists this many rejected groups, the largest, and sums up the rest (a
scene without ground, such as OpenCV's aloe, has 80)."""


def format_obstacle_table(obstacle_list: ObstacleList, calibrated: bool, *,
                          inputs: Mapping[str, Any] | None = None) -> str:
    """The obstacles as a plain-text table for a terminal, nearest first.

    Without a calibration the first line says that the values are pixels and disparities (and,
    when ``inputs`` say the pair was rectified from the images alone, how far they compare). The
    corridor summary and the largest rejected groups (with their reasons) follow the table.

    Examples
    --------
    >>> import numpy as np
    >>> from stereo_obstacles.obstacles import ObstacleList
    >>> print(format_obstacle_table(ObstacleList((), np.zeros((2, 2), np.int32)), True))
    No obstacles found.
    """
    lines = [] if calibrated else [units_note(False, inputs)]
    header, rows = _table(obstacle_list, calibrated)
    if rows:
        widths = [max(len(cell) for cell in column) for column in zip(header, *rows)]
        for cells in (header, *rows):
            lines.append("  ".join(cell.rjust(width) for cell, width in zip(cells, widths)).rstrip())
    else:
        lines.append("No obstacles found.")
    corridor = _corridor_sentence(obstacle_list)
    if corridor:
        lines.append(corridor)
    rejected = sorted(obstacle_list.rejected, key=lambda group: -group.pixel_count)
    for group in rejected[:MAX_REJECTED_LINES]:
        lines.append(f"Rejected {group.pixel_count} px at box {','.join(map(str, group.box_px))}: {group.reason}")
    if len(rejected) > MAX_REJECTED_LINES:
        rest = rejected[MAX_REJECTED_LINES:]
        lines.append(f"Rejected {len(rest)} smaller groups too ({sum(g.pixel_count for g in rest)} px; every one with "
                     f"its reason in obstacles.json)")
    return "\n".join(lines)


_STYLE = """
body { font-family: system-ui, sans-serif; margin: 1.5em auto; max-width: 75em; padding: 0 1em; color: #222; }
h1 { margin-bottom: 0.2em; } .summary { font-size: 1.15em; }
table { border-collapse: collapse; margin: 0.5em 0 1em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: right; }
th { background: #f2f2f2; } td.text { text-align: left; }
.note { background: #fff4d6; border-left: 4px solid #e0a800; padding: 0.5em 0.8em; }
figure { display: inline-block; margin: 0 1em 1em 0; vertical-align: top; }
img { max-width: 100%; border: 1px solid #999; } pre { background: #f6f6f6; padding: 0.8em; overflow-x: auto; }
footer { margin-top: 2em; color: #666; font-size: 0.9em; }
"""


def _html_table(header: list[str], rows: list[list[str]], text_columns: tuple[int, ...] = (),
                first_cell_colours: list[tuple[int, int, int]] | None = None) -> str:
    """An HTML table; ``first_cell_colours`` paints each row's first cell (the obstacle's colour)."""
    def cell(i: int, text: str, r: int) -> str:
        attributes = ' class="text"' if i in text_columns else ""
        if i == 0 and first_cell_colours is not None:
            rgb = first_cell_colours[r]
            ink = "#000" if 0.299 * rgb[0] + 0.587 * rgb[1] + 0.114 * rgb[2] > 140 else "#fff"
            attributes += f' style="background: rgb{tuple(rgb)}; color: {ink}; font-weight: bold"'
        return f"<td{attributes}>{html.escape(text)}</td>"

    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(cell(i, c, r) for i, c in enumerate(row)) + "</tr>\n"
                   for r, row in enumerate(rows))
    return f"<table>\n<tr>{head}</tr>\n{body}</table>"


def _html_report(obstacle_list: ObstacleList, calibration: StereoCalibration | None, *, pictures: list[str],
                 data_files: list[str], config: Mapping[str, Any], timings: Mapping[str, float],
                 inputs: Mapping[str, Any]) -> str:
    calibrated = calibration is not None
    doc = obstacles_to_dict(obstacle_list, calibration, config=config, timings_s=timings, inputs=inputs)
    summary = "; ".join(describe_detection(obstacle_list, calibrated,
                                           nearer_by_disparity=not rectified_from_images(inputs)))
    parts = [f'<h1>Obstacles</h1>\n<p class="summary">{html.escape(summary)}.</p>']
    if not calibrated:
        parts.append(f'<p class="note">{html.escape(units_note(False, inputs))}</p>')
    if "obstacles.png" in pictures:
        parts.append('<figure><img src="obstacles.png" alt="left image with obstacle boxes and distances">'
                     '<figcaption>Each obstacle is tinted and boxed in its own colour with its id and '
                     f'{"distance" if calibrated else "disparity"}.</figcaption></figure>')
    header, rows = _table(obstacle_list, calibrated)
    parts.append("<h2>Obstacles, nearest first</h2>")
    colours = [obstacle_colour(o.id) for o in obstacle_list.obstacles]
    parts.append(_html_table(header, rows, first_cell_colours=colours) if rows else "<p>No obstacles found.</p>")
    corridor = _corridor_sentence(obstacle_list)
    if corridor:
        parts.append(f"<h2>Walking corridor</h2>\n<p>{html.escape(corridor)}</p>")
    parts.append("<h2>Rejected groups</h2>")
    rejected = [[",".join(map(str, g.box_px)), str(g.pixel_count), g.reason] for g in obstacle_list.rejected]
    parts.append(_html_table(["box x0,y0,x1,y1 [px]", "pixels", "reason"], rejected, text_columns=(2,))
                 if rejected else "<p>None.</p>")
    parts.append("<h2>Pictures</h2>")
    parts.extend(f'<figure><img src="{name}" alt="{html.escape(PICTURE_TITLES[name])}">'
                 f"<figcaption>{html.escape(PICTURE_TITLES[name])}</figcaption></figure>"
                 for name in pictures if name != "obstacles.png")
    links = "".join(f'<li><a href="{name}">{name}</a>: {html.escape(DATA_DESCRIPTIONS[name])}</li>'
                    for name in data_files)
    parts.append(f"<h2>Files</h2>\n<ul>{links}</ul>")
    if timings:
        rows = [[str(stage), f"{float(seconds) * 1000:.1f}"] for stage, seconds in timings.items()]
        if "total" not in timings:
            rows.append(["total", f"{sum(float(v) for v in timings.values()) * 1000:.1f}"])
        parts.append("<h2>Timings</h2>\n" + _html_table(["stage", "time [ms]"], rows, text_columns=(0,)))
    if inputs:
        rows = [[str(k), str(v)] for k, v in doc["run"]["inputs"].items()]
        parts.append("<h2>Inputs</h2>\n" + _html_table(["input", "value"], rows, text_columns=(0, 1)))
    if calibrated:
        parts.append("<h2>Calibration</h2>\n<pre>" + html.escape(json.dumps(doc["calibration"], indent=2)) + "</pre>")
    parts.append("<h2>Configuration</h2>\n<pre>" + html.escape(json.dumps(doc["run"].get("config", {}), indent=2))
                 + "</pre>")
    parts.append(f"<footer>Written by stereo-obstacles {html.escape(__version__)}. Coordinates: "
                 f"{html.escape(doc['frame']['name'])}, x right, y down, z forward.</footer>")
    return ("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
            "<title>stereo-obstacles: detection report</title>\n"
            f"<style>{_STYLE}</style>\n</head>\n<body>\n" + "\n".join(parts) + "\n</body>\n</html>\n")


def _check_inputs(left: np.ndarray, labels: np.ndarray, disparity: np.ndarray, depth_m: np.ndarray | None,
                  obstacle_list: ObstacleList, calibration: StereoCalibration | None) -> None:
    shape = np.shape(disparity)
    if np.asarray(left).dtype not in (np.uint8, np.uint16) or np.ndim(left) != 3 or np.shape(left)[2] != 3:
        raise InvalidInputError(f"left must be uint8 RGB (H, W, 3) or uint16, got {np.asarray(left).dtype} "
                                f"{np.shape(left)}")
    if len(shape) != 2:
        raise InvalidInputError(f"disparity must be (H, W), got shape {shape}")
    arrays = {"left": np.shape(left)[:2], "labels": np.shape(labels),
              "obstacle_list.id_map": np.shape(obstacle_list.id_map)}
    if depth_m is not None:
        arrays["depth_m"] = np.shape(depth_m)
    for name, other in arrays.items():
        if other != shape:
            raise InvalidInputError(f"{name} is {other} but the disparity is {shape}; all must be the same size")
    if calibration is not None and depth_m is None:
        raise InvalidInputError("depth_m is needed with a calibration (depth.npy and points.ply are written from it)")
    if calibration is None and depth_m is not None:
        raise InvalidInputError("depth_m was given without a calibration; pass the calibration it came from")


CALIBRATED_ONLY = ("depth.npy", "points.ply", "depth_picture.png", "scan_picture.png")
"""Files of a detection written only with a calibration (the scan's picture: when the obstacle
list has a scan, as every calibrated detection's has)."""

def holds_a_report(folder) -> bool:
    """Whether ``folder`` holds a report this tool wrote: an ``obstacles.json`` of its format."""
    return is_document_of(Path(folder) / "obstacles.json", OBSTACLES_FORMAT)


def check_report_folder(folder) -> None:
    """Raise :class:`OutputError` when a report written into ``folder`` would replace files that
    are not an earlier report's: a rendered scene's ground truth (``scene.json`` beside it), an
    ``obstacles.json`` of another kind, or, without a report of this tool there, any file of
    the names a report writes (:data:`OUTPUT_FILES`: a user's own ``index.html``) but those a
    report's move put there or was replacing when it was cut short (killed, interrupted:
    :func:`stereo_obstacles.atomic.refuse_foreign_files`)."""
    folder = Path(folder)
    if (folder / "scene.json").is_file():
        raise OutputError(f"{folder} holds a rendered scene: its obstacles.json, labels.png, depth.npy and "
                          f"disparity.pfm are the ground truth; write the report elsewhere")
    if (folder / "obstacles.json").is_file() and not holds_a_report(folder):
        raise OutputError(f"{folder} holds an obstacles.json that is not a report of this tool; write the report "
                          f"elsewhere")
    refuse_foreign_files(folder, OUTPUT_FILES, ours=holds_a_report(folder), what="report",
                         missing="no obstacles.json of it, nor files a report's move cut short left")


FORMER_PICTURE_NAMES = ("disparity.png", "depth.png")
"""The pictures' former names, removed when a report is written again over a report of the
former kind (an ``obstacles.json`` without a ``disparity_picture.png``): read the way the
README's format table reads a ``.png`` disparity or depth (16-bit values), they are wrong. In
any other folder, a current report's included, a file of these names is the user's and stays."""

OUTPUT_FILES = ("obstacles.json", "disparity.pfm", "labels.png", "obstacles.png", "disparity_picture.png",
                "labels_picture.png", "index.html") + CALIBRATED_ONLY
"""Every file :func:`write_detection_outputs` may write into its folder."""


def write_detection_outputs(out_dir: str | os.PathLike[str], *, left: np.ndarray, labels: np.ndarray,
                            disparity: np.ndarray, depth_m: np.ndarray | None, obstacle_list: ObstacleList,
                            calibration: StereoCalibration | None, config: Mapping[str, Any],
                            timings: Mapping[str, float], inputs: Mapping[str, Any]) -> list[Path]:
    """Write the data files, pictures and ``index.html`` of one detection into ``out_dir``.

    All or nothing: on any error ``out_dir`` is left as it was. Files already in ``out_dir``
    with other names are kept; files of the same names are replaced, and the
    :data:`CALIBRATED_ONLY` files of an earlier report that this one does not write (without a
    calibration, or without a scan) are removed.

    Parameters
    ----------
    out_dir
        Output folder (created if missing).
    left
        ``uint8 (H, W, 3)`` RGB left image (``uint16`` is scaled to 8 bits).
    labels
        ``uint8 (H, W)`` phase-1 labels.
    disparity
        ``float32 (H, W)`` disparity in pixels, NaN where unmatched.
    depth_m
        ``float32 (H, W)`` depth in metres with a calibration; ``None`` without one.
    obstacle_list
        The measured obstacles.
    calibration
        The calibration, or ``None`` (then no depth files, values in pixels).
    config
        The resolved configuration of the run (stored in the JSON and shown in the report).
    timings
        Seconds per stage, in pipeline order.
    inputs
        Input file names (or other description of the inputs).

    Returns
    -------
    list of pathlib.Path
        The files written, in the order of the table in this module's documentation.

    Raises
    ------
    OutputError
        ``out_dir`` holds a rendered scene, another tool's ``obstacles.json``, or files of the
        report's names that are not an earlier report of this tool (:func:`check_report_folder`),
        or cannot be written.
    InvalidInputError
        Arrays of other shapes or types than above.
    """
    _check_inputs(left, labels, disparity, depth_m, obstacle_list, calibration)
    for name, mapping in (("config", config), ("timings", timings), ("inputs", inputs)):
        if not isinstance(mapping, Mapping):
            raise InvalidInputError(f"{name} must be a mapping (a dict), got {type(mapping).__name__}")
    check_report_folder(out_dir)                         # the commands check it first too
    (left,) = to_uint8(left)
    calibrated = calibration is not None
    data_files = ["obstacles.json", "disparity.pfm"] + (["depth.npy"] if calibrated else []) + ["labels.png"]
    data_files += ["points.ply"] if calibrated else []
    with_scan = calibrated and obstacle_list.scan is not None
    pictures = (["obstacles.png", "disparity_picture.png"] + (["depth_picture.png"] if calibrated else [])
                + ["labels_picture.png"] + (["scan_picture.png"] if with_scan else []))
    earlier_report = holds_a_report(out_dir)                             # else the files there are the user's
    former_kind = earlier_report and not (Path(out_dir) / "disparity_picture.png").is_file()
    # a report cut short while moving in counts too: its depth files go when this one has none
    ours = earlier_report or bool(moved_in_files(out_dir, "report") & set(OUTPUT_FILES))
    stale = (tuple(name for name in CALIBRATED_ONLY if ours and name not in data_files + pictures)
             + (FORMER_PICTURE_NAMES if former_kind else ()))
    with staged_directory(out_dir, last=("obstacles.json", "index.html"), stale=stale, kind="report") as stage:
        write_obstacles_json(stage / "obstacles.json", obstacle_list, calibration,
                             config=config, timings_s=timings, inputs=inputs)
        write_pfm(stage / "disparity.pfm", disparity)
        write_labels(stage / "labels.png", np.asarray(labels))
        if calibrated:
            write_depth(stage / "depth.npy", depth_m)
            write_ply(stage / "points.ply", points_from_depth(depth_m, calibration), left,
                      comments=[f"image size {np.shape(disparity)[1]}x{np.shape(disparity)[0]}"])
            write_image(stage / "depth_picture.png", depth_picture(depth_m))
        write_image(stage / "obstacles.png", draw_obstacles(left, obstacle_list, calibrated=calibrated,
                                                            nearer_by_disparity=not rectified_from_images(inputs)))
        write_image(stage / "disparity_picture.png", disparity_picture(disparity))
        write_image(stage / "labels_picture.png", labels_picture(np.asarray(labels)))
        if with_scan:
            write_image(stage / "scan_picture.png", scan_picture(obstacle_list.scan))
        write_text_atomic(stage / "index.html", _html_report(obstacle_list, calibration, pictures=pictures,
                                                             data_files=data_files, config=config,
                                                             timings=timings, inputs=inputs))
    written = [Path(out_dir) / name for name in data_files + pictures + ["index.html"]]
    logger.info("wrote %d files to %s", len(written), out_dir)
    return written


__all__ = ["format_obstacle_table", "write_detection_outputs"]
