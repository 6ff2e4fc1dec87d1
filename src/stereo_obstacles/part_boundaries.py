"""Two parts of a group of pixels and the boundary where they touch: a step or a crease.

Where two surfaces meet in the image, their disparities tell a step (a near object before a far
one) from a crease (two faces of one box) only away from the boundary: the matching's 5 x 5
windows, matched at half size, blur a step over about 8 pixels, and a blurred step reads as a
slope. So each part's plane ``d = a x + b y + c`` is fitted to its pixels farther than
``FIT_MARGIN_PX`` from the other part, and the two planes are compared where the parts touch:
a crease is where they meet all along the boundary, a step where they stay apart all along it
(:func:`step_at`, a percentile of the planes' difference over the boundary pixels). A part that
shows two faces of a box is not one plane; :func:`planes_near_boundary` fits the band of it next
to the boundary instead.

Large groups are handled on one pixel of each ``s`` x ``s`` square (:class:`PixelCanvas`), which
stands for its square's pixels in every pixel count; distances are in full-size pixels, at
least one square. Used by :mod:`stereo_obstacles.colour_split`.
"""

from __future__ import annotations

import functools
import math

import cv2
import numpy as np

from stereo_obstacles._colour_split_kernel import one_per_block_kernel
from stereo_obstacles.plane_fit import MIN_ROBUST_POINTS, plane_at, robust_plane
from stereo_obstacles.quantiles import percentile

BOUNDARY_PX = 2.0
"""Pixels within this distance (at least one square) of the other part are where the two parts
touch."""
FIT_MARGIN_PX = 8.0
"""Each part's plane is fitted to its pixels farther than this from the other part."""
NEAR_BAND_WIDTH_PX = 16.0
"""The planes near the boundary (:func:`planes_near_boundary`) are fitted to the pixels from
``FIT_MARGIN_PX`` to ``FIT_MARGIN_PX + NEAR_BAND_WIDTH_PX`` (8-24 px) from the other part; no
other width was measured (``docs/pipeline.md``, session 44)."""
NEAR_BAND_MIN_SPAN_PX = 24.0
"""A part's near band pins a plane down when the bounding box of its pixels spans at least this
many full-size pixels in column and in row; a thinner band (a pole's, or a strip along a
boundary that runs along a row or a column) keeps the part's plane fitted farther out (without
this, scene 840 gained a repeated detection; ``docs/pipeline.md``, session 44)."""
MIN_TOUCHING_PIXELS = 10
"""Parts with fewer decided pixels (one per square in a large group) along their boundary do not
touch."""
PLANE_TOLERANCE_PX, PLANE_TOLERANCE_REL = 0.5, 0.02
"""A pixel lies on a plane when its disparity is within ``PLANE_TOLERANCE_PX + PLANE_TOLERANCE_REL
* d`` pixels of it."""
HOLE_BRIDGE_PX = 3.0
"""Pieces whose pixels lie up to twice this apart (full-size pixels; on a large group's squares,
rounded up to whole squares) across holes are one piece (:meth:`PixelCanvas.small_pieces`)."""
MAX_DECISION_PIXELS = 8000
"""A larger set of ``n`` pixels is handled on one pixel of each ``s`` x ``s`` square, ``s =
ceil(sqrt(n / MAX_DECISION_PIXELS))``."""

Plane = tuple[float, float, float]


class PixelCanvas:
    """Pixels ``(ys, xs)``, one per ``block`` x ``block`` square, each standing for ``weights``
    pixels of its square, on the image of their bounding box in squares, for image operations
    on them; distances and pixel counts in full-size pixels."""

    def __init__(self, ys: np.ndarray, xs: np.ndarray, block: int, weights: np.ndarray) -> None:
        self.ys, self.xs, self.block, self.weights = ys, xs, block, weights

    @classmethod
    def of_pixels(cls, ys: np.ndarray, xs: np.ndarray) -> tuple[PixelCanvas, np.ndarray, np.ndarray]:
        """The canvas of the pixels ``(ys, xs)`` (1-D, int64): one per square of the side
        ``MAX_DECISION_PIXELS`` sets (the first pixel in each), the indices of those pixels, and
        for each pixel the index of its square's among them."""
        block = max(1, math.ceil(math.sqrt(len(ys) / MAX_DECISION_PIXELS)))
        rows, columns = ys // block, xs // block
        chosen, square_of = one_per_block_kernel(rows - rows.min(), columns - columns.min())
        canvas = cls(ys[chosen], xs[chosen], block, np.bincount(square_of, minlength=len(chosen)))
        return canvas, chosen, square_of

    @functools.cached_property
    def _grid(self) -> tuple[np.ndarray, np.ndarray, tuple[int, int]]:
        """Each pixel's square row and column from the box's corner, and the box's shape in squares."""
        rows, columns = self.ys // self.block, self.xs // self.block
        rows, columns = rows - rows.min(), columns - columns.min()
        return rows, columns, (int(rows.max()) + 1, int(columns.max()) + 1)

    @functools.cached_property
    def _holes(self) -> np.ndarray:
        """``bool`` image of the box in squares: the squares that hold none of these pixels."""
        rows, columns, shape = self._grid
        holes = np.ones(shape, dtype=bool)
        holes[rows, columns] = False
        return holes

    def subset(self, index: np.ndarray) -> PixelCanvas:
        """The canvas of the pixels ``index`` (an index array into these)."""
        return PixelCanvas(self.ys[index], self.xs[index], self.block, self.weights[index])

    def pixels(self, where: np.ndarray | None = None) -> int:
        """Full-size pixels that these (where ``where``, ``bool (n,)``, holds) stand for."""
        return int(self.weights.sum() if where is None else self.weights[where].sum())

    def distance_to(self, where: np.ndarray) -> np.ndarray:
        """``float32 (n,)`` distance (full-size pixels) of each pixel to the nearest pixel where
        ``where`` (``bool (n,)``) holds; large where none does."""
        rows, columns, shape = self._grid
        free = np.full(shape, 255, dtype=np.uint8)
        free[rows[where], columns[where]] = 0
        return cv2.distanceTransform(free, cv2.DIST_L2, 3)[rows, columns] * self.block

    def small_pieces(self, where: np.ndarray, min_pixels: int) -> np.ndarray:
        """``bool (n,)``: pixels where ``where`` holds in pieces standing for fewer than
        ``min_pixels`` full-size pixels.

        Pieces are 8-connected, also across holes up to ``HOLE_BRIDGE_PX`` (full-size pixels,
        rounded up to whole squares) from a pixel where ``where`` holds: the blobs of a sparsely
        matched face form one piece. A hole is a square of the canvas's bounding box that holds
        none of its pixels: an unmatched pixel or one outside the group (also beyond its outline,
        so that pieces along the outline may join around it) and, on the canvas of one part
        (:meth:`subset`), a pixel of the other part. The canvas's pixels where ``where`` does not
        hold are never crossed. Only the pixels where ``where`` holds count towards a piece's size."""
        rows, columns, shape = self._grid
        image = np.zeros(shape, dtype=np.uint8)
        image[rows[where], columns[where]] = 1
        radius = math.ceil(HOLE_BRIDGE_PX / self.block)
        reach = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * radius + 1, 2 * radius + 1))
        bridged = np.where(self._holes & (cv2.dilate(image, reach) > 0), np.uint8(1), image)
        n_pieces, pieces = cv2.connectedComponents(bridged, connectivity=8)
        piece_of = pieces[rows, columns]
        small = np.bincount(piece_of[where], weights=self.weights[where], minlength=n_pieces) < min_pixels
        small[0] = False
        return where & small[piece_of]


def distance_to_other(canvas: PixelCanvas, second: np.ndarray) -> np.ndarray:
    """``float32 (n,)``: each pixel's distance (full-size pixels) to the nearest pixel of the other
    part; ``second`` (``bool (n,)``) says which pixels form the second part."""
    return np.where(second, canvas.distance_to(~second), canvas.distance_to(second))


def planes_away_from_boundary(canvas: PixelCanvas, d: np.ndarray, second: np.ndarray,
                              to_other: np.ndarray) -> tuple[Plane, Plane] | None:
    """The robust planes of the first and the second part (``d``: float64 ``(n,)`` disparities),
    each fitted to its pixels farther than ``FIT_MARGIN_PX`` from the other part (to all of them
    when fewer than ``MIN_ROBUST_POINTS`` are); None when either pins no plane down."""
    planes = []
    for members in (~second, second):
        inner = members & (to_other > FIT_MARGIN_PX)
        fitted = inner if np.count_nonzero(inner) >= MIN_ROBUST_POINTS else members
        plane = robust_plane(canvas.xs[fitted], canvas.ys[fitted], d[fitted])
        if plane is None:
            return None
        planes.append(plane)
    return planes[0], planes[1]


def planes_near_boundary(canvas: PixelCanvas, d: np.ndarray, second: np.ndarray, to_other: np.ndarray,
                         farther_out: tuple[Plane, Plane]) -> tuple[Plane, Plane]:
    """The planes of the first and the second part nearest the boundary: each part's robust plane
    of its pixels in the band from ``FIT_MARGIN_PX`` to ``FIT_MARGIN_PX + NEAR_BAND_WIDTH_PX``
    from the other part, where that band pins a plane down (:func:`_pins_plane`) and the robust
    fit succeeds; else the part's plane in ``farther_out`` (those of
    :func:`planes_away_from_boundary`).

    A box that shows two faces has no one plane: fitted across both, its plane leans from the face
    that touches the boundary towards the other one, and the step to an object in front of the
    touching face can vanish in the lean. The band reads mostly the face at the boundary (all of
    it where that face reaches 24 px or more from the boundary)."""
    planes = []
    for members, plane in zip((~second, second), farther_out):
        band = members & (to_other > FIT_MARGIN_PX) & (to_other <= FIT_MARGIN_PX + NEAR_BAND_WIDTH_PX)
        near = robust_plane(canvas.xs[band], canvas.ys[band], d[band]) if _pins_plane(canvas, band) else None
        planes.append(plane if near is None else near)
    return planes[0], planes[1]


def _pins_plane(canvas: PixelCanvas, band: np.ndarray) -> bool:
    """Whether the pixels ``band`` (``bool (n,)``) pin down a plane read beyond them: at least
    ``MIN_ROBUST_POINTS`` of them (one per square on a large group; none leaves no span to
    measure), their bounding box spanning ``NEAR_BAND_MIN_SPAN_PX`` in column and in row."""
    if np.count_nonzero(band) < MIN_ROBUST_POINTS:
        return False
    return min(np.ptp(canvas.xs[band]), np.ptp(canvas.ys[band])) >= NEAR_BAND_MIN_SPAN_PX


def boundary(canvas: PixelCanvas, to_other: np.ndarray) -> np.ndarray | None:
    """``bool (n,)``: the pixels within ``BOUNDARY_PX`` (at least the next square) of the other
    part; None when fewer than ``MIN_TOUCHING_PIXELS`` are (the parts do not touch)."""
    touching = to_other <= max(BOUNDARY_PX, canvas.block)
    return touching if np.count_nonzero(touching) >= MIN_TOUCHING_PIXELS else None


def step_at(canvas: PixelCanvas, touching: np.ndarray, planes: tuple[Plane, Plane], q: float) -> float:
    """The step (pixels of disparity) between the two planes along the boundary pixels
    ``touching``: the ``q``-th percentile of their difference there (a low one: the planes stay
    apart all along it when it is large; a high one: they meet all along it when it is small)."""
    xs, ys = canvas.xs[touching], canvas.ys[touching]
    return percentile(np.abs(plane_at(planes[0], xs, ys) - plane_at(planes[1], xs, ys)), q)


def on_plane_fraction(canvas: PixelCanvas, d: np.ndarray, members: np.ndarray, plane: Plane) -> float:
    """Share of the pixels ``members`` (``bool (n,)``, counted by the pixels each stands for) whose
    disparity ``d`` lies on ``plane`` (within ``PLANE_TOLERANCE_PX + PLANE_TOLERANCE_REL * d``)."""
    xs, ys, values, weights = canvas.xs[members], canvas.ys[members], d[members], canvas.weights[members]
    on = np.abs(values - plane_at(plane, xs, ys)) <= PLANE_TOLERANCE_PX + PLANE_TOLERANCE_REL * np.abs(values)
    return float(weights[on].sum() / weights.sum())
