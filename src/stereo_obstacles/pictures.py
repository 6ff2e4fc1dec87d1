"""Pictures a person looks at: obstacles over the left image, disparity, depth and labels with legends.

Every function returns an RGB ``uint8`` picture. Text is drawn with OpenCV's Hershey font,
scaled to the image width, on a filled background so that it stays readable on any scene.
Legends and colour bars are a panel under the picture, at least :data:`MIN_PANEL_WIDTH_PX`
wide (a narrow picture is padded with black on the right).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import cv2
import numpy as np

from stereo_obstacles.colorize import colorize_depth, colorize_disparity
from stereo_obstacles.direction_scan import DirectionScan
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.labels import LABEL_COLOURS_RGB, Label, colorize_labels
from stereo_obstacles.obstacles import Obstacle, ObstacleList

OBSTACLE_COLOURS_RGB: tuple[tuple[int, int, int], ...] = (
    (255, 64, 64), (255, 170, 0), (0, 200, 255), (200, 80, 255), (80, 230, 80),
    (255, 90, 200), (255, 230, 40), (40, 120, 255), (150, 255, 200), (255, 140, 110),
)
"""Colour of obstacle ``id`` is ``OBSTACLE_COLOURS_RGB[(id - 1) % 10]`` (box, label and tint)."""

REJECTED_COLOUR_RGB = (170, 170, 170)
TINT_ALPHA = 0.45
"""Weight of an obstacle's colour over its own pixels."""

MIN_PANEL_WIDTH_PX = 240
_FONT = cv2.FONT_HERSHEY_SIMPLEX


def obstacle_colour(obstacle_id: int) -> tuple[int, int, int]:
    """The RGB colour obstacle ``obstacle_id`` (1, 2, ...) is drawn with."""
    return OBSTACLE_COLOURS_RGB[(obstacle_id - 1) % len(OBSTACLE_COLOURS_RGB)]


def _panel_scale(width_px: int) -> float:
    """Font scale of the text in panels under a picture ``width_px`` wide."""
    return float(np.clip(width_px / 1000.0, 0.4, 0.75))


def _overlay_scale(height_px: int, width_px: int) -> float:
    """Font scale of the captions drawn over an image: grows with its size, readable when small."""
    return float(np.clip(math.sqrt(height_px * width_px) / 1100.0, 0.42, 0.9))


def _text_colour_on(rgb: tuple[int, int, int]) -> tuple[int, int, int]:
    luminance = 0.299 * rgb[0] + 0.587 * rgb[1] + 0.114 * rgb[2]
    return (0, 0, 0) if luminance > 140 else (255, 255, 255)


def _label_rect(text: str, x: int, y: int, scale: float, shape: tuple[int, ...]) -> tuple[int, int, int, int]:
    """``(x, y, width, height)`` of a caption with its top-left corner at ``(x, y)``, moved inside ``shape``."""
    (text_w, text_h), baseline = cv2.getTextSize(text, _FONT, scale, 1)
    pad = max(2, int(round(3 * scale)))
    box_w, box_h = text_w + 2 * pad, text_h + baseline + 2 * pad
    return (int(np.clip(x, 0, max(0, shape[1] - box_w))), int(np.clip(y, 0, max(0, shape[0] - box_h))), box_w, box_h)


def _put_label(image: np.ndarray, text: str, x: int, y: int, background: tuple[int, int, int],
               scale: float) -> tuple[int, int, int, int]:
    """Write ``text`` on a filled box whose top-left corner is ``(x, y)``, kept inside the image.

    Returns the ``(x, y, width, height)`` of the box drawn.
    """
    rect = _label_rect(text, x, y, scale, image.shape)
    x, y, box_w, box_h = rect
    (_, text_h), _ = cv2.getTextSize(text, _FONT, scale, 1)
    pad = max(2, int(round(3 * scale)))
    cv2.rectangle(image, (x, y), (x + box_w - 1, y + box_h - 1), background, thickness=cv2.FILLED)
    cv2.putText(image, text, (x + pad, y + pad + text_h), _FONT, scale, _text_colour_on(background), 1,
                cv2.LINE_AA)
    return rect


def _overlaps(a: tuple[int, int, int, int], b: tuple[int, int, int, int]) -> bool:
    return a[0] < b[0] + b[2] and b[0] < a[0] + a[2] and a[1] < b[1] + b[3] and b[1] < a[1] + a[3]


def _label_height(scale: float) -> int:
    (_, text_h), baseline = cv2.getTextSize("#0", _FONT, scale, 1)
    return text_h + baseline + 2 * max(2, int(round(3 * scale)))


def _as_rgb(image: np.ndarray, name: str) -> np.ndarray:
    a = np.asarray(image)
    if a.dtype != np.uint8 or not (a.ndim == 2 or (a.ndim == 3 and a.shape[2] == 3)):
        raise InvalidInputError(f"{name} must be uint8 RGB (H, W, 3) or grey (H, W), got {a.dtype} {a.shape}")
    return np.repeat(a[..., None], 3, axis=2) if a.ndim == 2 else a.copy()


def obstacle_caption(obstacle: Obstacle, calibrated: bool) -> str:
    """``"#1 2.35 m"``, or ``"#1 d=21.0 px"`` without a calibration."""
    if calibrated and obstacle.distance_m is not None:
        return f"#{obstacle.id} {obstacle.distance_m:.2f} m"
    return f"#{obstacle.id} d={obstacle.disparity_px:.1f} px"


def describe_detection(obstacle_list: ObstacleList, calibrated: bool, *, nearer_by_disparity: bool = True) -> list[str]:
    """Short sentences summing up a detection: count and nearest, corridor, units, rejections.
    ``nearer_by_disparity`` false: a larger disparity is nearer only locally (a pair rectified from
    the images alone)."""
    obstacles = obstacle_list.obstacles
    parts = [f"{len(obstacles)} obstacle{'s' if len(obstacles) != 1 else ''}"]
    if obstacles:
        parts[0] += f", nearest {obstacle_caption(obstacles[0], calibrated)}"
    corridor = obstacle_list.corridor
    if calibrated and corridor is not None:
        free = (f"free {corridor.free_distance_m:.2f} m to #{corridor.nearest_obstacle_id}"
                if corridor.nearest_obstacle_id is not None else "nothing found ahead")
        parts.append(f"{corridor.width_m:g} m corridor: {free}")
    if not calibrated:
        parts.append("no calibration: d = disparity in px, larger is nearer"
                     + ("" if nearer_by_disparity else " only between obstacles close together"))
    if obstacle_list.rejected:
        parts.append(f"{len(obstacle_list.rejected)} rejected (thin boxes without caption)")
    return parts


def draw_obstacles(left_rgb: np.ndarray, obstacle_list: ObstacleList, *, calibrated: bool,
                   nearer_by_disparity: bool = True) -> np.ndarray:
    """The left image with every obstacle tinted, boxed and labelled with its id and distance.

    Each obstacle's own pixels (``obstacle_list.id_map``) are tinted in its colour
    (:func:`obstacle_colour`), its box drawn and captioned ``"#1 2.35 m"`` (or
    ``"#1 d=21.0 px"`` without a calibration). The obstacle nearest in the walking corridor
    has a doubled box. Rejected groups get a thin grey box with a dark rim. Captions are placed nearest
    obstacle first, above, inside or below its box, where they cover no other caption; when
    there is no room the caption shrinks to ``"#3"``, and failing that it is left out (the
    panel says how many). A panel under the image sums up: count, nearest obstacle, the
    corridor's free distance, and whether values are pixels.

    Parameters
    ----------
    left_rgb
        ``uint8 (H, W, 3)`` RGB left image (or ``(H, W)`` grey).
    obstacle_list
        The measured obstacles; its ``id_map`` must be ``(H, W)``.
    calibrated
        Whether distances in metres are shown (else disparities in pixels).
    nearer_by_disparity
        Without a calibration, whether the panel says a larger disparity is nearer everywhere
        (false: only between obstacles close together, as :func:`describe_detection`).

    Returns
    -------
    numpy.ndarray
        ``uint8 (H + panel, max(W, MIN_PANEL_WIDTH_PX), 3)`` RGB picture; the image is at the top left.
    """
    out = _as_rgb(left_rgb, "left_rgb")
    id_map = np.asarray(obstacle_list.id_map)
    if id_map.shape != out.shape[:2]:
        raise InvalidInputError(f"obstacle_list.id_map is {id_map.shape}, the left image {out.shape[:2]}")
    h, w = id_map.shape
    palette = np.array([(0, 0, 0), *OBSTACLE_COLOURS_RGB], dtype=np.float32)
    tinted = id_map > 0
    colours = palette[(id_map[tinted] - 1) % len(OBSTACLE_COLOURS_RGB) + 1]
    out[tinted] = np.rint((1 - TINT_ALPHA) * out[tinted] + TINT_ALPHA * colours).astype(np.uint8)
    scale = _overlay_scale(h, w)
    thickness = max(1, int(round(math.sqrt(h * w) / 400)))
    for group in obstacle_list.rejected:
        x0, y0, x1, y1 = group.box_px
        cv2.rectangle(out, (x0 - 1, y0 - 1), (x1, y1), (0, 0, 0), 1)  # dark rim: visible on light ground
        cv2.rectangle(out, (x0, y0), (x1 - 1, y1 - 1), REJECTED_COLOUR_RGB, 1)
    corridor = obstacle_list.corridor
    corridor_id = corridor.nearest_obstacle_id if corridor is not None else None
    for obstacle in reversed(obstacle_list.obstacles):  # nearest drawn last, on top
        x0, y0, x1, y1 = obstacle.box_px
        colour = obstacle_colour(obstacle.id)
        cv2.rectangle(out, (x0, y0), (x1 - 1, y1 - 1), colour, thickness)
        if obstacle.id == corridor_id:
            cv2.rectangle(out, (x0 - 2 * thickness, y0 - 2 * thickness),
                          (x1 - 1 + 2 * thickness, y1 - 1 + 2 * thickness), colour, thickness)
    placed: list[tuple[int, int, int, int]] = []
    left_out = 0
    for obstacle in obstacle_list.obstacles:  # the nearest get the best places
        x0, y0, x1, y1 = obstacle.box_px
        for text in (obstacle_caption(obstacle, calibrated), f"#{obstacle.id}"):
            text_h = _label_rect(text, 0, 0, scale, out.shape)[3]
            spots = [(x0, y0 - text_h), (x0, y0 + thickness), (x0, y1 + thickness)]  # above, inside, below
            free = [spot for spot in spots if not any(_overlaps(_label_rect(text, *spot, scale, out.shape), r)
                                                      for r in placed)]
            if free:
                placed.append(_put_label(out, text, *free[0], obstacle_colour(obstacle.id), scale))
                break
        else:
            left_out += 1
    parts = describe_detection(obstacle_list, calibrated, nearer_by_disparity=nearer_by_disparity)
    if left_out:
        parts.append(f"{left_out} caption{'s' if left_out != 1 else ''} left out for lack of room (see the table)")
    return _stack_with_panel(out, _text_panel(parts, w))


def _panel(width_px: int, height_px: int) -> np.ndarray:
    return np.full((height_px, width_px, 3), 32, dtype=np.uint8)


def _text_panel(parts: list[str], width_px: int) -> np.ndarray:
    """A panel with ``parts`` joined by " | " and wrapped at spaces into lines that fit ``width_px``.

    A part starts on a new line unless it fits whole after the previous one.
    """
    width = max(width_px, MIN_PANEL_WIDTH_PX)
    scale = _panel_scale(width)

    def fits(text: str) -> bool:
        return cv2.getTextSize(text, _FONT, scale, 1)[0][0] + 12 <= width

    lines: list[str] = []
    for part in parts:
        if lines and fits(f"{lines[-1]} | {part}"):
            lines[-1] = f"{lines[-1]} | {part}"
            continue
        lines.append("")
        for word in part.split():
            if lines[-1] and not fits(f"{lines[-1]} {word}"):
                lines.append("")
            lines[-1] = f"{lines[-1]} {word}".strip()
    row_h = _label_height(scale)
    panel = _panel(width, len(lines) * row_h + 6)
    for i, line in enumerate(lines):
        _put_label(panel, line, 4, 3 + i * row_h, (32, 32, 32), scale)
    return panel


def _stack_with_panel(picture: np.ndarray, panel: np.ndarray) -> np.ndarray:
    """``picture`` above ``panel``; the narrower of the two is padded with black on the right."""
    width = max(picture.shape[1], panel.shape[1])

    def pad(a):
        return np.pad(a, ((0, 0), (0, width - a.shape[1]), (0, 0)))

    return np.concatenate([pad(picture), pad(panel)], axis=0)


def labels_picture(labels: np.ndarray) -> np.ndarray:
    """The label image in the colours of :data:`~stereo_obstacles.labels.LABEL_COLOURS_RGB`, with a legend.

    The legend under the picture lists the labels present in the image with their colour and
    the share of pixels each covers.

    Parameters
    ----------
    labels
        ``uint8 (H, W)`` label image (values of :class:`~stereo_obstacles.labels.Label`).

    Returns
    -------
    numpy.ndarray
        ``uint8 (H + legend, max(W, MIN_PANEL_WIDTH_PX), 3)`` RGB picture.
    """
    a = np.asarray(labels)
    if a.ndim != 2 or a.dtype != np.uint8:
        raise InvalidInputError(f"labels must be uint8 (H, W), got {a.dtype} {a.shape}")
    counts = np.bincount(a.ravel(), minlength=256)
    present = [label for label in Label if counts[label] > 0]
    unknown_values = int(counts.sum() - sum(counts[label] for label in Label))
    width = max(a.shape[1], MIN_PANEL_WIDTH_PX)
    scale = _panel_scale(width)
    row_h = _label_height(scale)
    entries = [(label.name.lower(), LABEL_COLOURS_RGB[label], counts[label]) for label in present]
    if unknown_values:
        entries.append(("other values", (0, 0, 0), unknown_values))
    texts = [f"{name} {100.0 * n / a.size:.0f}%" for name, _, n in entries]
    widths = [row_h + 6 + cv2.getTextSize(t, _FONT, scale, 1)[0][0] + 14 for t in texts]
    positions, x, y = [], 6, 4
    for item_w in widths:  # flow the entries into rows
        if x + item_w > width and x > 6:
            x, y = 6, y + row_h + 4
        positions.append((x, y))
        x += item_w
    panel = _panel(width, y + row_h + 6)
    for (px, py), (_, rgb, _), text in zip(positions, entries, texts):
        cv2.rectangle(panel, (px, py + 2), (px + row_h - 4, py + row_h - 2), rgb, cv2.FILLED)
        cv2.rectangle(panel, (px, py + 2), (px + row_h - 4, py + row_h - 2), (200, 200, 200), 1)
        _put_label(panel, text, px + row_h, py, (32, 32, 32), scale)
    return _stack_with_panel(colorize_labels(a), panel)


def _nice_step(raw: float) -> float:
    """The smallest of 1, 2, 2.5, 5 times a power of ten that is >= ``raw`` (> 0)."""
    power = 10.0 ** math.floor(math.log10(raw))
    return next(m * power for m in (1.0, 2.0, 2.5, 5.0, 10.0) if m * power >= raw * (1 - 1e-9))


def _nice_ceil(value: float) -> float:
    """``value`` rounded up to a multiple of a round step (about a quarter of it)."""
    step = _nice_step(value / 4.0)
    return math.ceil(value / step - 1e-9) * step


def _ticks(lo: float, hi: float) -> np.ndarray:
    step = _nice_step((hi - lo) / 5.0)
    return np.arange(math.ceil(lo / step - 1e-9), math.floor(hi / step + 1e-9) + 1) * step


def _colour_bar(colorize: Callable[[np.ndarray], np.ndarray], lo: float, hi: float, title: str,
                width_px: int) -> np.ndarray:
    """A panel with ``title`` over a horizontal colour bar from ``lo`` to ``hi`` with round ticks."""
    width = max(width_px, MIN_PANEL_WIDTH_PX)
    scale = _panel_scale(width)
    row_h = _label_height(scale)
    ticks = _ticks(lo, hi)
    texts = [f"{round(float(t), 9):g}" for t in ticks]
    margin = max(cv2.getTextSize(t, _FONT, scale, 1)[0][0] for t in texts) // 2 + 8
    bar_w, bar_h, top = width - 2 * margin, max(10, row_h), row_h + 4
    panel = _panel(width, top + bar_h + 4 + row_h + 4)
    _put_label(panel, title, 4, 2, (32, 32, 32), scale)
    ramp = (lo + (np.arange(bar_w) + 0.5) / bar_w * (hi - lo)).astype(np.float32)[None, :].repeat(bar_h, axis=0)
    panel[top:top + bar_h, margin:margin + bar_w] = colorize(ramp)
    for value, text in zip(ticks, texts):
        x = margin + int(round((value - lo) / (hi - lo) * (bar_w - 1)))
        cv2.line(panel, (x, top + bar_h), (x, top + bar_h + 3), (230, 230, 230), 1)
        text_w = cv2.getTextSize(text, _FONT, scale, 1)[0][0]
        _put_label(panel, text, x - text_w // 2 - 3, top + bar_h + 3, (32, 32, 32), scale)
    return panel


def _as_float_map(array: np.ndarray, name: str) -> np.ndarray:
    a = np.asarray(array)
    if a.ndim != 2 or not np.issubdtype(a.dtype, np.floating):
        raise InvalidInputError(f"{name} must be a float (H, W) map with NaN for invalid, got {a.dtype} {a.shape}")
    return a.astype(np.float32, copy=False)


def _check_range(name: str, lo: float, hi: float) -> None:
    if not (math.isfinite(lo) and math.isfinite(hi) and hi > lo):
        raise InvalidInputError(f"{name} range must be finite with the maximum above the minimum, got [{lo}, {hi}]")


def disparity_picture(disparity: np.ndarray, *, vmin: float | None = None, vmax: float | None = None) -> np.ndarray:
    """Disparity in the turbo colour map (invalid black), with a colour bar in pixels under it.

    Parameters
    ----------
    disparity
        ``float (H, W)`` disparity in pixels, NaN where unmatched.
    vmin, vmax
        Range of the colour map in pixels; by default the 1st and 99th percentiles of the
        valid disparities, rounded outwards to whole pixels. Values outside are clipped.

    Returns
    -------
    numpy.ndarray
        ``uint8 (H + bar, max(W, MIN_PANEL_WIDTH_PX), 3)`` RGB picture.
    """
    d = _as_float_map(disparity, "disparity")
    valid = d[np.isfinite(d)]
    lo_auto, hi_auto = (np.percentile(valid, [1.0, 99.0]) if valid.size else (0.0, 1.0))
    lo = float(math.floor(lo_auto)) if vmin is None else float(vmin)
    hi = float(math.ceil(hi_auto)) if vmax is None else float(vmax)
    if vmax is None and hi <= lo:
        hi = lo + 1.0
    _check_range("disparity", lo, hi)
    share = 100.0 * valid.size / max(d.size, 1)
    bar = _colour_bar(lambda ramp: colorize_disparity(ramp, vmin=lo, vmax=hi), lo, hi,
                      f"disparity [px]; {share:.0f}% of pixels matched; black = no disparity", d.shape[1])
    return _stack_with_panel(colorize_disparity(d, vmin=lo, vmax=hi), bar)


def depth_picture(depth_m: np.ndarray, *, max_m: float | None = None) -> np.ndarray:
    """Depth in the magma colour map, near bright and far dark (unknown black), with a colour bar in metres.

    Parameters
    ----------
    depth_m
        ``float (H, W)`` depth in metres, NaN where unknown.
    max_m
        Depth at the end of the colour map; farther depths get its colour. By default the
        75th percentile of the known depths rounded up to a round number, so that the near
        range, where obstacles matter and depth is accurate, gets most of the colours.

    Returns
    -------
    numpy.ndarray
        ``uint8 (H + bar, max(W, MIN_PANEL_WIDTH_PX), 3)`` RGB picture.
    """
    z = _as_float_map(depth_m, "depth_m")
    valid = z[np.isfinite(z) & (z > 0)]
    if max_m is None:
        max_m = _nice_ceil(float(np.percentile(valid, 75.0))) if valid.size else 1.0
    _check_range("depth", 0.0, float(max_m))
    bar = _colour_bar(lambda ramp: colorize_depth(ramp, max_m), 0.0, float(max_m),
                      f"depth [m]; near bright, {max_m:g} m and beyond darkest; black = unknown", z.shape[1])
    return _stack_with_panel(colorize_depth(z, max_m), bar)


SCAN_PICTURE_SIZE_PX = (640, 400)
"""Width and height of :func:`scan_picture`'s top view, without its legend."""

FREE_RGB = (200, 230, 200)
"""Top view: a sector free up to its nearest obstacle."""

UNSEEN_RGB = (90, 90, 90)
"""Top view: a sector with no obstacle reported."""

ARC_STEP_DEG = 1.0
"""Arcs of the top view are drawn as straight pieces of at most this many degrees."""


class _TopView:
    """Pixel positions of a top view: the camera at the bottom centre, ``max_range_m`` at the
    top edge or at the side edges (whichever the field of view reaches first)."""

    def __init__(self, field_of_view_deg: tuple[float, float], max_range_m: float) -> None:
        width, height = SCAN_PICTURE_SIZE_PX
        self.origin = np.array([width / 2.0, height - 12.0])
        widest = math.sin(math.radians(min(89.0, max(abs(b) for b in field_of_view_deg))))
        self.px_per_m = min((height - 24.0) / max_range_m, (width / 2.0 - 8.0) / (max_range_m * max(widest, 1e-3)))

    def at(self, bearing_deg: float, range_m: float) -> tuple[int, int]:
        """The pixel ``(x, y)`` of the point at ``range_m`` along ``bearing_deg``."""
        b = math.radians(bearing_deg)
        x, y = self.origin + self.px_per_m * range_m * np.array([math.sin(b), -math.cos(b)])
        return int(round(x)), int(round(y))

    def arc(self, first_deg: float, last_deg: float, range_m: float) -> list[tuple[int, int]]:
        """The pixels of the arc at ``range_m`` from ``first_deg`` to ``last_deg``."""
        steps = max(1, math.ceil((last_deg - first_deg) / ARC_STEP_DEG))
        return [self.at(b, range_m) for b in np.linspace(first_deg, last_deg, steps + 1)]


def _seen_sectors(scan: DirectionScan):
    """``(first, last, range, id)`` of each sector, its bearings cut to the field of view."""
    low, high = scan.field_of_view_deg
    for k, (rng, obstacle) in enumerate(zip(scan.ranges_m, scan.obstacle_ids)):
        start = scan.first_bearing_deg + k * scan.sector_deg
        first, last = max(start, low), min(start + scan.sector_deg, high)
        if first < last:
            yield first, last, rng, obstacle


def _name_obstacles(out: np.ndarray, view: _TopView, scan: DirectionScan, max_range_m: float, scale: float,
                    taken: list[tuple[int, int, int, int]]) -> None:
    """Write ``#id`` over each obstacle's nearest sector, nearest first, where a name fits beside
    the labels already written (``taken``: their ``(x, y, width, height)``)."""
    nearest: dict[int, tuple[float, float]] = {}
    for first, last, rng, obstacle in _seen_sectors(scan):
        if obstacle is not None and rng <= max_range_m and rng < nearest.get(obstacle, (math.inf,))[0]:
            nearest[obstacle] = (rng, (first + last) / 2)
    drawn = list(taken)
    for obstacle, (rng, bearing) in sorted(nearest.items(), key=lambda item: item[1][0]):
        x, y = view.at(bearing, rng)
        rect = _label_rect(f"#{obstacle}", x - 10, y - _label_height(scale) - 4, scale, out.shape)
        if not any(_overlaps(rect, other) for other in drawn):
            drawn.append(_put_label(out, f"#{obstacle}", rect[0], rect[1], obstacle_colour(obstacle), scale))


def scan_picture(scan: DirectionScan, *, max_range_m: float | None = None) -> np.ndarray:
    """The free range per direction seen from above: the camera at the bottom centre, each
    sector of bearing (within the field of view) a wedge, free (light green) up to its nearest
    obstacle, drawn as an arc in that obstacle's colour and named at its nearest sector (nearest
    first, where a name fits); sectors with no obstacle reported are grey. Rings mark the range.

    Parameters
    ----------
    scan
        The scan (:mod:`stereo_obstacles.direction_scan`).
    max_range_m
        Range at the top edge; by default the farthest range of the scan rounded up (10 m when
        it has none).

    Returns
    -------
    numpy.ndarray
        ``uint8`` RGB picture: :data:`SCAN_PICTURE_SIZE_PX` with a legend panel under it.

    Raises
    ------
    InvalidInputError
        ``max_range_m`` not a finite number > 0.
    """
    ranges = [r for r in scan.ranges_m if r is not None]
    if max_range_m is None:
        max_range_m = _nice_ceil(max(ranges) * 1.05) if ranges else 10.0
    _check_range("scan", 0.0, float(max_range_m))
    width, height = SCAN_PICTURE_SIZE_PX
    out = np.full((height, width, 3), 32, np.uint8)
    view = _TopView(scan.field_of_view_deg, max_range_m)
    for first, last, rng, _ in _seen_sectors(scan):
        wedge = [view.at(0.0, 0.0)] + view.arc(first, last, min(rng, max_range_m) if rng is not None else max_range_m)
        cv2.fillPoly(out, [np.array(wedge, np.int32)], FREE_RGB if rng is not None else UNSEEN_RGB)
    scale = _panel_scale(width)
    step = _nice_step(max_range_m / 4.0)
    rings = []
    for ring in np.arange(step, max_range_m + 1e-9, step):
        cv2.circle(out, view.at(0.0, 0.0), int(round(view.px_per_m * ring)), (150, 150, 150), 1, cv2.LINE_AA)
        x, y = view.at(0.0, ring)
        rings.append(_put_label(out, f"{ring:g} m", x + 3, y + 1, (32, 32, 32), scale))
    for first, last, rng, obstacle in _seen_sectors(scan):
        if rng is not None and rng <= max_range_m:
            cv2.polylines(out, [np.array(view.arc(first, last, rng), np.int32)], False,
                          obstacle_colour(obstacle) if obstacle else REJECTED_COLOUR_RGB, 3, cv2.LINE_AA)
    _name_obstacles(out, view, scan, max_range_m, scale, rings)
    legend = [f"top view, camera at the bottom centre; {scan.sector_deg:g} deg sectors of bearing",
              "light: free up to the nearest obstacle (arc in its colour)", "grey: no obstacle reported"]
    return _stack_with_panel(out, _text_panel(legend, width))


__all__ = ["OBSTACLE_COLOURS_RGB", "obstacle_colour", "obstacle_caption", "describe_detection",
           "draw_obstacles", "labels_picture", "disparity_picture", "depth_picture", "scan_picture"]
