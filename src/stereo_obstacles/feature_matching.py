"""Sparse feature matches between two images (SIFT or ORB), for rectification and its check.

Keypoints are detected in both images, matched by nearest descriptor, and kept when they pass
Lowe's ratio test (the best match is clearly better than the second best) and the mutual
check (each is the other's best match). No geometric model is fitted here.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.fileio import to_uint8

logger = logging.getLogger(__name__)

METHODS = ("sift", "orb")
"""Feature detectors: SIFT (default, subpixel keypoints) or ORB (faster, binary)."""


@dataclass(frozen=True, eq=False)
class FeatureMatches:
    """Putative correspondences.

    Attributes
    ----------
    left_px, right_px : ndarray of float64, shape (N, 2)
        ``(x, y)`` pixel coordinates of matched keypoints in the left and right images.
    n_left, n_right : int
        Keypoints detected in each image.
    """

    left_px: np.ndarray
    right_px: np.ndarray
    n_left: int
    n_right: int

    def __post_init__(self) -> None:
        if self.left_px.shape != self.right_px.shape or self.left_px.ndim != 2 or self.left_px.shape[1] != 2:
            raise InvalidInputError(f"left_px, right_px: expected (N, 2) of one shape, got "
                                    f"{self.left_px.shape} and {self.right_px.shape}")

    def __len__(self) -> int:
        return int(self.left_px.shape[0])


def _grey(image: np.ndarray, name: str) -> np.ndarray:
    """The grey ``(H, W)`` copy of a grey or RGB image, in its own dtype."""
    import cv2

    if not isinstance(image, np.ndarray) or image.ndim not in (2, 3) or (image.ndim == 3 and image.shape[2] != 3):
        raise InvalidInputError(f"{name}: expected a grey (H, W) or RGB (H, W, 3) image, got "
                                f"{getattr(image, 'shape', type(image).__name__)}")
    return cv2.cvtColor(image, cv2.COLOR_RGB2GRAY) if image.ndim == 3 else image


def _grey_pair_uint8(left: np.ndarray, right: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Both images as ``uint8 (H, W)`` grey: 16-bit ones scaled together by their significant
    bits (:func:`~stereo_obstacles.fileio.to_uint8`: 12-bit data keeps its contrast, and a pair
    keeps one scale), float ones stretched from their minimum to their maximum."""
    greys = [_grey(left, "left"), _grey(right, "right")]
    wide = iter(to_uint8(*(grey for grey in greys if grey.dtype == np.uint16)))
    return tuple(np.ascontiguousarray(grey) if grey.dtype == np.uint8 else next(wide) if grey.dtype == np.uint16
                 else _stretched_uint8(grey) for grey in greys)


def _stretched_uint8(grey: np.ndarray) -> np.ndarray:
    finite = np.nan_to_num(grey.astype(np.float64))
    lo, hi = float(finite.min()), float(finite.max())
    return np.zeros(grey.shape, np.uint8) if hi <= lo else ((finite - lo) * (255.0 / (hi - lo))).astype(np.uint8)


def match_features(left: np.ndarray, right: np.ndarray, *, method: str = "sift", ratio: float = 0.75,
                   max_features: int = 4000, orb_levels: int = 8) -> FeatureMatches:
    """Match keypoints of ``left`` and ``right`` by descriptor (ratio test and mutual check).

    Parameters
    ----------
    left, right : ndarray, shape (H, W) or (H, W, 3)
        Grey or RGB images (any size each; usually one stereo pair).
    method : {"sift", "orb"}
        Detector and descriptor.
    ratio : float
        Lowe's ratio test, in (0, 1]: keep a match when its descriptor distance is below
        ``ratio`` times that of the second best.
    max_features : int
        Keypoints kept per image (the strongest).
    orb_levels : int
        Pyramid levels of the ORB detector (OpenCV's default 8, scale factor 1.2 each; ignored
        by SIFT). Fewer levels are faster and enough when both images show the scene at one
        scale, as a stereo pair does.

    Returns
    -------
    FeatureMatches

    Raises
    ------
    InvalidInputError
        Not images, or an option out of range.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> image = (rng.uniform(0, 255, (120, 160)) > 128).astype(np.uint8) * 255
    >>> matches = match_features(image, np.roll(image, -5, axis=1))
    >>> bool(np.median(matches.left_px[:, 0] - matches.right_px[:, 0]) == 5.0)
    True
    """
    import cv2

    if method not in METHODS:
        raise InvalidInputError(f"method: expected one of {list(METHODS)}, got {method!r}")
    if not 0.0 < ratio <= 1.0:
        raise InvalidInputError(f"ratio: expected 0 < ratio <= 1, got {ratio}")
    if int(max_features) != max_features or max_features < 8:
        raise InvalidInputError(f"max_features: expected an integer >= 8, got {max_features}")
    if isinstance(orb_levels, bool) or int(orb_levels) != orb_levels or not 1 <= orb_levels <= 16:
        raise InvalidInputError(f"orb_levels: expected an integer from 1 to 16, got {orb_levels}")
    grey_left, grey_right = _grey_pair_uint8(left, right)
    if method == "sift":
        detector = cv2.SIFT_create(nfeatures=int(max_features))
        norm = cv2.NORM_L2
    else:
        detector = cv2.ORB_create(nfeatures=int(max_features), nlevels=int(orb_levels))
        norm = cv2.NORM_HAMMING
    kp_left, desc_left = detector.detectAndCompute(grey_left, None)
    kp_right, desc_right = detector.detectAndCompute(grey_right, None)
    empty = np.zeros((0, 2))
    if desc_left is None or desc_right is None or len(kp_left) < 2 or len(kp_right) < 2:
        return FeatureMatches(empty, empty.copy(), len(kp_left), len(kp_right))
    matcher = cv2.BFMatcher(norm)
    forward = matcher.knnMatch(desc_left, desc_right, k=2)
    backward = {m.queryIdx: m.trainIdx for m in matcher.match(desc_right, desc_left)}
    pairs = [(best.queryIdx, best.trainIdx) for best, second in (p for p in forward if len(p) == 2)
             if best.distance < ratio * second.distance and backward.get(best.trainIdx) == best.queryIdx]
    left_px = np.array([kp_left[i].pt for i, _ in pairs], dtype=np.float64).reshape(-1, 2)
    right_px = np.array([kp_right[j].pt for _, j in pairs], dtype=np.float64).reshape(-1, 2)
    logger.debug("%s: %d and %d keypoints, %d matches", method, len(kp_left), len(kp_right), len(pairs))
    return FeatureMatches(left_px, right_px, len(kp_left), len(kp_right))


