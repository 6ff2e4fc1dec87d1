"""Matches the right camera cannot see: half-occluded pixels matched anyway.

A point seen by the left camera at column ``x`` with disparity ``d`` is seen by the right
camera at column ``x - d``. Beside the left edge of a near object, the left camera sees a strip
of the background that the near object hides from the right camera. No correct match exists
there, yet a matcher may find one: the scanline search and the growth then pair these pixels
with whatever right-image texture is free, often the near object's own, which puts a phantom
surface between the two depths (a cylinder 8.3 m away, seen only beside a pole 2.7 m away,
was reported at 4.1 m; ``docs/pipeline.md``, "Held-out scenes").

The test: every match, together with the next match of its row when the two are at most
``max_gap_px`` columns apart and within ``surface_tolerance_px`` of each other (one surface
with a small hole), covers the right-image columns it projects to. A match is *hidden* when its
own right-image column is covered by a surface more than ``min_depth_gap_px`` nearer: the right
camera sees that surface there, not this point. Neighbouring matches of one surface differ by
at most ``surface_tolerance_px``, which may not exceed the gap, so they do not hide each other.

The test trusts the near surface. Where the matcher has fattened it (background pixels beside
its left edge given its disparity), the hidden strip it implies lies that much further left and
takes correct background matches with it. Rendered as the evaluation renders them (3 x 3 rays),
the built-in scene loses 8 of its 200 492 matches, all within 1 px of the truth; scene 3, 7 of
169 591, all within 1 px; scene 42, 73 of 174 200, of which 35 within 1 px and the rest the
phantom (``docs/pipeline.md``, "Held-out scenes"). The correct matches lost are few; the
phantoms kept would be obstacles at wrong distances.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from stereo_obstacles._visibility_kernel import hidden_in_right_kernel
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import plain_numbers
from stereo_obstacles.thread_pool import run_in_threads

THREADS = 2
"""The rows are tested in this many chunks at once (each row is independent of the others), as many as
the matcher's row bands (:data:`stereo_obstacles.matching.BANDS`): one per core of the 2-core target."""


@dataclass(frozen=True)
class VisibilityParameters:
    """When a match counts as hidden from the right camera.

    Attributes
    ----------
    max_gap_px : int
        Two matches of a row at most this many columns apart (and within
        ``surface_tolerance_px``) are one surface: the right-image columns between their
        projections are covered too, so a hole of unmatched pixels in a near object does not
        let a far match through.
    surface_tolerance_px : float
        Largest disparity difference, in pixels, between two neighbouring matches of one
        surface.
    min_depth_gap_px : float
        A match is hidden only behind a surface more than this many pixels of disparity nearer;
        at least ``surface_tolerance_px``.
    """

    max_gap_px: int = 3
    surface_tolerance_px: float = 2.0
    min_depth_gap_px: float = 2.0

    def __post_init__(self) -> None:
        plain_numbers(self)                      # NumPy scalars as Python numbers (JSON-ready)
        if isinstance(self.max_gap_px, bool) or not isinstance(self.max_gap_px, (int, np.integer)) \
                or self.max_gap_px < 1:
            raise InvalidInputError(f"max_gap_px must be an integer >= 1, got {self.max_gap_px!r}")
        for name in ("surface_tolerance_px", "min_depth_gap_px"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise InvalidInputError(f"{name} must be a finite number >= 0, got {value!r}")
        if self.surface_tolerance_px > self.min_depth_gap_px:
            raise InvalidInputError(f"surface_tolerance_px ({self.surface_tolerance_px}) must not exceed "
                                    f"min_depth_gap_px ({self.min_depth_gap_px}): one surface would hide itself")


def hidden_in_right(disparity: np.ndarray, params: VisibilityParameters = VisibilityParameters()) -> np.ndarray:
    """Which matches of a left disparity map the right camera cannot see.

    Parameters
    ----------
    disparity
        ``float (H, W)`` left disparity in pixels, NaN (or inf) where unmatched; values larger
        than twice the width count as unmatched.
    params
        See :class:`VisibilityParameters`.

    Returns
    -------
    numpy.ndarray
        ``bool (H, W)``, True for matches hidden behind a nearer matched surface in the right
        image (module docstring); False elsewhere, including unmatched pixels.

    Examples
    --------
    >>> d = np.full((1, 60), np.nan, np.float32)
    >>> d[0, 40:50] = 20.0      # a near pole, seen at right-image columns 20..29
    >>> d[0, 30] = 6.0          # left of it: right-image column 24, behind the pole
    >>> d[0, 55] = 6.0          # right of it: column 49, in the open
    >>> np.flatnonzero(hidden_in_right(d)[0]).tolist()
    [30]
    """
    d = np.asarray(disparity)
    if d.ndim != 2:
        raise InvalidInputError(f"disparity must be a 2-D map, got shape {d.shape}")
    with np.errstate(over="ignore"):  # float64 beyond float32's range becomes inf: unmatched
        d32 = np.ascontiguousarray(d, dtype=np.float32)
    settings = (int(params.max_gap_px), float(params.surface_tolerance_px), float(params.min_depth_gap_px))
    # chunks of equal work, as the refinement does: the matches crowd in the lower rows (ground), not the sky
    work = np.cumsum(np.count_nonzero(np.isfinite(d32), axis=1))
    bounds = [0] + [int(np.searchsorted(work, work[-1] * i / THREADS)) for i in range(1, THREADS)] + [d32.shape[0]]
    chunks = run_in_threads(hidden_in_right_kernel, [(d32[a:b], *settings) for a, b in zip(bounds[:-1], bounds[1:])])
    return np.concatenate(chunks, axis=0)
