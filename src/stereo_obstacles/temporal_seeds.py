"""Temporal seeds: the previous frame's matches seed the next frame's growth.

The authors of Growing Correspondence Seeds suggest it for sequences: consecutive frames of a
video differ little, so a sparse grid of last frame's correspondences lands on or next to the
right disparity in the new frame, and the growth fills in the rest. It replaces the edge-seed
stage (a scanline search per edge pixel), which is the costly part of the seeds; the growth,
the final stable matching and ``tau`` are unchanged, so a wrong seed (something moved) is not
accepted unless its similarity passes the same test as any other candidate.

With a calibration and the forward motion of the rig per frame, each seed is moved to where a
static point is expected in the next frame: ``Z' = Z - forward_m``, ``x' = cx + (x - cx) Z / Z'``
(the same for ``y``), ``d' = f B / Z' - doffs``.

Regions that come into view are only reached by growth from their neighbours, so
:class:`TemporalSeeder` goes back to edge seeds every ``refresh_every`` frames and whenever
the previous frame left too few seeds.

Going further (``refine_frames``): between grown frames, a frame may skip seeds and growth
altogether, every pixel matched in the previous frame being matched again near its previous
disparity on the full-size pair (:func:`temporal_estimate`,
:func:`stereo_obstacles.scaled_matching.refine_at_full_size`). That is the cheapest frame, but
it finds nothing the previous frame had not matched (beyond one pixel around it), so the
grown frames in between bring in what comes into view (measured in ``docs/streams.md``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import check_integers, check_numbers

__all__ = ["TemporalSeedParameters", "TemporalSeeder", "temporal_estimate", "temporal_seed_points"]


@dataclass(frozen=True)
class TemporalSeedParameters:
    """How the previous frame's matches become the next frame's seeds.

    Attributes
    ----------
    step_px : int
        Seeds are the matched pixels on a grid of this step in x and y (pixels, >= 1).
    refresh_every : int
        One frame in this many uses the matcher's edge seeds (frames 0, N, 2N, ...); 0: only
        the first frame and frames after too few temporal seeds were left.
    min_seeds : int
        Fewer temporal seeds than this and the frame uses edge seeds.
    forward_m_per_frame : float
        Expected forward motion of the rig between frames in metres (needs a calibration to
        be used; 0 keeps the seeds where they were).
    refine_frames : int
        After each frame matched by growth, this many frames are matched by refining the
        latest grown frame's disparity instead (no seeds, no growth; see the module docstring);
        0: every frame grows. ``refresh_every`` counts the grown frames only. The default 1
        (every other frame refined) is the fastest setting whose frames stayed within 1.2 %
        bad-1 on the synthetic walk; 2 and 3 let some frames reach 2.2-3.4 % (figures in
        ``docs/streams.md``).
    """

    step_px: int = 8
    refresh_every: int = 30
    min_seeds: int = 100
    forward_m_per_frame: float = 0.0
    refine_frames: int = 1

    def __post_init__(self) -> None:
        check_integers(self, (("step_px", 1, math.inf), ("refresh_every", 0, math.inf), ("min_seeds", 0, math.inf),
                              ("refine_frames", 0, math.inf)))
        check_numbers(self, (("forward_m_per_frame", -5.0, 5.0),))   # metres


def temporal_seed_points(disparity: np.ndarray, *, d_min: int, d_max: int, step_px: int = 8,
                         calibration: StereoCalibration | None = None, forward_m: float = 0.0) -> np.ndarray:
    """Seeds ``(x, y, d)`` for the next frame from this frame's disparity map.

    Parameters
    ----------
    disparity : ndarray of float, shape (H, W)
        This frame's left disparity in pixels, NaN where unmatched.
    d_min, d_max : int
        Disparity range of the next match, pixels; seeds outside it are dropped.
    step_px : int
        Grid step in pixels: matched pixels with ``x % step == 0`` and ``y % step == 0``.
    calibration : StereoCalibration, optional
        Needed to move the seeds by ``forward_m``.
    forward_m : float
        Expected forward motion of the rig until the next frame, metres.

    Returns
    -------
    ndarray of float64, shape (N, 3)
        Rows ``(x, y, d)`` with integer values, inside the image with ``x - d >= 0``.

    Raises
    ------
    InvalidInputError
        ``disparity`` is not 2-D, ``step_px < 1``, or ``forward_m`` is non-zero without a
        calibration.

    Examples
    --------
    >>> import numpy as np
    >>> d = np.full((4, 8), np.nan, np.float32); d[0, 4] = 2.2; d[2, 6] = 3.0
    >>> temporal_seed_points(d, d_min=0, d_max=5, step_px=2)
    array([[4., 0., 2.],
           [6., 2., 3.]])
    """
    disparity = np.asarray(disparity)
    if disparity.ndim != 2:
        raise InvalidInputError(f"disparity must be 2-D (H, W), got shape {disparity.shape}")
    if int(step_px) != step_px or step_px < 1:
        raise InvalidInputError(f"step_px must be an integer >= 1, got {step_px}")
    if forward_m != 0.0 and calibration is None:
        raise InvalidInputError("forward_m needs a calibration to move the seeds")
    h, w = disparity.shape
    grid = disparity[::step_px, ::step_px].astype(np.float64)
    rows, cols = np.nonzero(np.isfinite(grid))
    y = rows * float(step_px)
    x = cols * float(step_px)
    d = grid[rows, cols]
    if forward_m != 0.0:
        x, y, d = _move_forward(x, y, d, calibration, forward_m)
    x, y, d = np.rint(x), np.rint(y), np.rint(d)
    keep = (x >= 0) & (x < w) & (y >= 0) & (y < h) & (d >= d_min) & (d <= d_max) & (x - d >= 0)
    return np.stack([x[keep], y[keep], d[keep]], axis=1)


def temporal_estimate(disparity: np.ndarray) -> np.ndarray:
    """The disparity estimate a frame gives the next one to refine: its own disparity, and at each
    unmatched pixel next to a match (8-neighbourhood) the largest neighbouring disparity.

    Not moved by the rig's motion: the refinement climbs up to 2 px from every estimate, more
    than the disparity of a point changes over a few frames at walking speed; where it changes
    more, the pixel goes unmatched (``docs/streams.md``).

    Parameters
    ----------
    disparity : ndarray of float, shape (H, W)
        Disparity in pixels, NaN where unmatched.

    Returns
    -------
    ndarray of float32, shape (H, W)

    Examples
    --------
    >>> import numpy as np
    >>> d = np.full((3, 4), np.nan, np.float32); d[1, 1] = 5.0; d[1, 2] = 6.0
    >>> temporal_estimate(d)
    array([[5., 6., 6., 6.],
           [5., 5., 6., 6.],
           [5., 6., 6., 6.]], dtype=float32)
    """
    disparity = np.asarray(disparity, np.float32)
    if disparity.ndim != 2:
        raise InvalidInputError(f"disparity must be 2-D (H, W), got shape {disparity.shape}")
    matched = np.isfinite(disparity)
    known = np.where(matched, disparity, -np.inf).astype(np.float32)
    spread = cv2.dilate(known, np.ones((3, 3), np.uint8), borderType=cv2.BORDER_CONSTANT, borderValue=-np.inf)
    return np.where(matched, disparity, np.where(np.isfinite(spread), spread, np.nan)).astype(np.float32)


def _move_forward(x: np.ndarray, y: np.ndarray, d: np.ndarray, calibration: StereoCalibration,
                  forward_m: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where static points seen at ``(x, y, d)`` appear after the rig moved ``forward_m``."""
    d_total = d + calibration.doffs_px
    with np.errstate(divide="ignore", invalid="ignore"):
        z = calibration.focal_baseline_px_m / d_total
        z_new = z - forward_m
        ratio = z / z_new
    ahead = (d_total > 0) & (z_new > 0)
    x_new = calibration.cx_px + (x - calibration.cx_px) * ratio
    y_new = calibration.cy_px + (y - calibration.cy_px) * ratio
    d_new = d_total * ratio - calibration.doffs_px
    return x_new[ahead], y_new[ahead], d_new[ahead]


class TemporalSeeder:
    """Decides per frame between edge seeds and the previous frame's matches.

    Call :meth:`estimate` before matching a frame: if it returns a disparity estimate, refine
    it (``detect(disparity_estimate=...)``); otherwise call :meth:`seeds` (``None`` means: use
    the edge seeds). Call :meth:`observe` with the frame's disparity afterwards.

    Parameters
    ----------
    params : TemporalSeedParameters
    calibration : StereoCalibration, optional
        Used to move the seeds by ``params.forward_m_per_frame``.
    """

    def __init__(self, params: TemporalSeedParameters = TemporalSeedParameters(),
                 calibration: StereoCalibration | None = None) -> None:
        self.params = params
        self.calibration = calibration
        self._points: np.ndarray | None = None
        self._estimate: np.ndarray | None = None
        self._since_refresh = 0
        self._refined_in_a_row = 0

    def estimate(self) -> np.ndarray | None:
        """The disparity estimate the coming frame refines, or ``None``: that frame grows."""
        if self._estimate is None or self._refined_in_a_row >= self.params.refine_frames:
            self._refined_in_a_row = 0
            return None
        self._refined_in_a_row += 1
        return self._estimate

    def seeds(self) -> np.ndarray | None:
        """Seed points ``(N, 3)`` for the coming frame, or ``None`` for edge seeds."""
        refresh = self.params.refresh_every
        if self._points is None or len(self._points) < self.params.min_seeds \
                or (refresh and self._since_refresh + 1 >= refresh):
            self._since_refresh = 0
            return None
        self._since_refresh += 1
        return self._points

    def observe(self, disparity: np.ndarray, *, d_min: int, d_max: int, frames_ahead: int = 1,
                refined: bool = False) -> None:
        """Remember the seeds this frame's disparity gives the frame ``frames_ahead`` after it.

        A ``refined`` frame's disparity (matched from an estimate) does not become the next
        estimate: refined frames always refine a grown frame, so their errors do not add up."""
        forward = self.params.forward_m_per_frame * frames_ahead if self.calibration is not None else 0.0
        self._points = temporal_seed_points(disparity, d_min=d_min, d_max=d_max, step_px=self.params.step_px,
                                            calibration=self.calibration, forward_m=forward)
        if self.params.refine_frames and not refined:
            self._estimate = temporal_estimate(disparity)
