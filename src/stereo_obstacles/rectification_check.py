"""A check that a supposedly rectified pair really is rectified, before matching it.

The most common silent failure of stereo with real cameras is a pair that is not rectified:
the matcher then searches the wrong rows and returns a blank or garbage disparity map. This
check matches sparse features, keeps the matches that agree with a robust fundamental matrix,
and measures their vertical offsets; above :data:`MAX_MEDIAN_OFFSET_PX` (median) the pair is
reported as not rectified and a warning is logged.
"""

from __future__ import annotations

import logging
import threading
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from stereo_obstacles.feature_matching import match_features
from stereo_obstacles.image_pairs import check_same_size
from stereo_obstacles.rectification_quality import VerticalOffsetStats, vertical_offset_stats

logger = logging.getLogger(__name__)

MAX_MEDIAN_OFFSET_PX = 1.0
"""Median ``|vertical offset|`` of matched features above which a pair is called not rectified."""

MIN_MATCHES = 12
"""Fewer consistent matches than this and the check cannot say anything."""

SWAPPED_FRACTION = 0.8
"""Above this fraction of consistent matches lying to the right in the right image (negative
disparity), the pair is reported as swapped."""


@dataclass(frozen=True)
class RectificationCheck:
    """Outcome of :func:`check_rectification`.

    Attributes
    ----------
    offsets : VerticalOffsetStats
        Vertical offsets of the consistent feature matches, pixels.
    rectified : bool or None
        ``True`` when the median offset is at most ``threshold_px``, ``False`` above it,
        ``None`` when too few features matched to tell.
    threshold_px : float
        The limit used, pixels.
    swapped : bool or None
        ``True`` when most consistent matches have a negative disparity (the left and right
        images exchanged), ``None`` when too few features matched to tell.
    """

    offsets: VerticalOffsetStats
    rectified: bool | None
    threshold_px: float
    swapped: bool | None = None
    negative_fraction: float = 0.0
    """Fraction of the consistent matches with a negative disparity (what ``swapped`` is decided on)."""

    def to_dict(self) -> dict:
        """JSON-ready mapping."""
        return {"rectified": self.rectified, "threshold_px": self.threshold_px, "swapped": self.swapped,
                "vertical_offset": self.offsets.to_dict()}


def check_rectification(left: np.ndarray, right: np.ndarray, *, threshold_px: float = MAX_MEDIAN_OFFSET_PX,
                        method: str = "sift", warn: bool = True, max_side_px: int | None = None,
                        max_features: int = 4000, orb_levels: int = 8) -> RectificationCheck:
    """Measure whether ``left`` and ``right`` are rectified, warning when they are not.

    Parameters
    ----------
    left, right : ndarray, shape (H, W) or (H, W, 3)
        The pair as it will be matched, same size.
    threshold_px : float
        Largest acceptable median ``|vertical offset|`` of matched features, pixels (> 0).
    method : {"sift", "orb"}
        Feature detector.
    warn : bool
        Log a warning (``logging.warning``) when the pair is not rectified.
    max_side_px : int, optional
        Match features on copies shrunk so that their longer side is at most this (faster);
        offsets are scaled back to full-size pixels.
    max_features, orb_levels : int
        Keypoints kept per image and ORB pyramid levels
        (:func:`stereo_obstacles.feature_matching.match_features`).

    Returns
    -------
    RectificationCheck

    Raises
    ------
    InvalidInputError, ImageMismatchError
        Not images, images of different sizes, or ``threshold_px <= 0``.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> image = (rng.uniform(0, 255, (120, 160)) > 128).astype(np.uint8) * 255
    >>> check_rectification(image, np.roll(image, (3, -5), axis=(0, 1)), warn=False).rectified
    False
    """
    import cv2

    from stereo_obstacles.errors import InvalidInputError

    if not threshold_px > 0:
        raise InvalidInputError(f"threshold_px: expected > 0, got {threshold_px}")
    check_same_size(left, right)
    scale = 1.0
    if max_side_px is not None and max(left.shape[:2]) > max_side_px:
        scale = max(left.shape[:2]) / max_side_px
        size = (round(left.shape[1] / scale), round(left.shape[0] / scale))
        left, right = (cv2.resize(image, size, interpolation=cv2.INTER_AREA) for image in (left, right))
    matches = match_features(left, right, method=method, max_features=max_features, orb_levels=orb_levels)
    left_px, right_px = matches.left_px * scale, matches.right_px * scale
    if len(matches) >= 8:
        # Keep the matches consistent with one epipolar geometry (an unrectified pair has one too).
        # (RANSAC: the same verdicts as MAGSAC++ on 26 pairs at 1/20 of its time: docs/rectification.md)
        _, mask = cv2.findFundamentalMat(left_px, right_px, cv2.FM_RANSAC, 1.0, 0.999)
        if mask is not None:
            keep = mask.ravel().astype(bool)
            left_px, right_px = left_px[keep], right_px[keep]
    offsets = vertical_offset_stats(left_px, right_px)
    rectified = None if offsets.n_points < MIN_MATCHES else bool(offsets.median_px <= threshold_px)
    if rectified is False and warn:
        logger.warning("the pair does not look rectified: matched features are %.1f px apart vertically "
                       "(median; 95th percentile %.1f px, %d matches); the disparity will be poor -- rectify "
                       "it first (stereo-obstacles rectify, or --uncalibrated)", offsets.median_px,
                       offsets.p95_px, offsets.n_points)
    elif rectified is None and warn and not on_one_row(offsets, threshold_px, scale):
        logger.warning(UNCHECKED_WARNING, offsets.n_points, MIN_MATCHES)
    negative = float(np.mean(left_px[:, 0] - right_px[:, 0] < -0.5)) if len(left_px) else 0.0
    swapped = None if offsets.n_points < MIN_MATCHES else negative > SWAPPED_FRACTION
    if swapped and warn:
        logger.warning(SWAPPED_WARNING, 100 * negative, offsets.n_points)
    return RectificationCheck(offsets=offsets, rectified=rectified, threshold_px=float(threshold_px),
                              swapped=swapped, negative_fraction=negative)


MIN_JUDGED_MATCHES = 3
ONE_ROW_REACH = 1.5
"""Below :data:`MIN_MATCHES` the verdict is "cannot tell", and a warning says so unless at least
``MIN_JUDGED_MATCHES`` matches lie on one row: half of them within the threshold and 95 % within
``ONE_ROW_REACH`` times it in pixels of the images the features were matched on (``max_side_px``:
scene 9 at 1920x1440, matched shrunk 3x, has them within 2.1 full-size pixels; two scenes at
3840x2160 had 95 % within 4.8 px but half only within 2.9). Synthetic scene 9, a genuine pair of weak texture, gives the pipeline's check
(:func:`stereo_obstacles.pipeline.pair_rectification_check`: ORB on the pair shrunk) 7 matches
with a 95th percentile of 1.31 px and is not flagged; of the 1560 pairs of different synthetic scenes 0..39,
the 472 with 3 to 11 matches all lie farther apart (the nearest: 6 matches, 1.9 px; with the
median instead, 3 of them passed as one row), and 56 pairs of different shared real scenes gave
0-7 matches."""

def on_one_row(offsets: VerticalOffsetStats, threshold_px: float, scale: float) -> bool:
    """Whether matches too few for a verdict still lie on one row (:data:`ONE_ROW_REACH`): at
    least :data:`MIN_JUDGED_MATCHES`, half within ``threshold_px`` and 95 % within
    ``ONE_ROW_REACH * threshold_px`` pixels of the copy matched on, shrunk ``scale`` times
    (offsets in full-size pixels)."""
    return (offsets.n_points >= MIN_JUDGED_MATCHES and offsets.median_px <= threshold_px
            and offsets.p95_px <= ONE_ROW_REACH * threshold_px * max(scale, 1.0))


UNCHECKED_WARNING = ("the pair could not be checked: only %d feature matches agree with one stereo geometry (%d "
                     "needed); if the two images do not show one scene from two side-by-side cameras, the results "
                     "mean nothing")

SWAPPED_WARNING = ("the left and right images look swapped: %.0f %% of %d matched features lie further right in "
                   "the right image (negative disparity); give the left camera's image first")
"""The warning :func:`check_rectification` logs for a swapped pair (a logging format string)."""


class _WithoutSwappedWarning(logging.Filter):
    def filter(self, record: logging.LogRecord) -> bool:
        return record.msg is not SWAPPED_WARNING


_WITHOUT_SWAPPED_WARNING = _WithoutSwappedWarning()
_refusing = 0
_refusing_lock = threading.Lock()


@contextmanager
def refusing_swapped_pairs():
    """Within it, :func:`check_rectification` does not warn about a swapped pair: the caller
    refuses such a pair with :func:`refuse_swapped`, whose error says the same (the command line
    showed the sentence twice). Concurrent and nested uses (a batch's pairs) are counted; the
    warning comes back when the last one ends."""
    global _refusing
    with _refusing_lock:
        if _refusing == 0:
            logger.addFilter(_WITHOUT_SWAPPED_WARNING)
        _refusing += 1
    try:
        yield
    finally:
        with _refusing_lock:
            _refusing -= 1
            if _refusing == 0:
                logger.removeFilter(_WITHOUT_SWAPPED_WARNING)


def refuse_swapped(check: RectificationCheck | None) -> None:
    """Raise :class:`~stereo_obstacles.errors.ImageMismatchError` when ``check`` found the pair
    swapped: every disparity and obstacle of such a pair is wrong (the commands call this before
    writing anything)."""
    from stereo_obstacles.errors import ImageMismatchError

    if check is not None and check.swapped:
        raise ImageMismatchError(f"the left and right images look swapped ({100 * check.negative_fraction:.0f} % of "
                                 f"{check.offsets.n_points} matched features lie further right in the right image); "
                                 f"give the left camera's image first")
