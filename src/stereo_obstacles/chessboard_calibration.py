"""Stereo calibration from chessboard image pairs.

:func:`find_board` finds the inner corners of a chessboard (``cv2.findChessboardCorners``
refined by ``cv2.cornerSubPix``, falling back to ``cv2.findChessboardCornersSB``);
:func:`calibrate_pairs` calibrates each camera (``cv2.calibrateCamera``), then the pair
(``cv2.stereoCalibrate`` with the intrinsics as a starting guess), and measures the result:
the RMS reprojection error, and the *epipolar error after rectification* -- the vertical
offsets of corresponding corners once rectified with the new calibration.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from stereo_obstacles.camera_calibration import CameraPairCalibration
from stereo_obstacles.errors import CalibrationError, ImageMismatchError, InvalidInputError
from stereo_obstacles.rectification import Rectification, rectify_calibration
from stereo_obstacles.rectification_quality import VerticalOffsetStats, vertical_offset_stats

logger = logging.getLogger(__name__)

MIN_PAIRS = 3
"""Fewest usable pairs (board found in both images) accepted for a calibration."""

MAX_STEREO_RMS_FRACTION = 0.004
"""A stereo reprojection error above this fraction of the image diagonal means the corners do not
describe one rig seen twice. The shared chessboard set (640 x 480, diagonal 800 px) calibrates at
0.445 px (0.06 %), and at 3.2 px (0.07 %) enlarged six times; a board size that matches a different
part of the board in each image gave 20.5-20.7 px (2.6 %). The limit is 3.2 px at 640 x 480."""


@dataclass(frozen=True)
class Board:
    """A chessboard: inner corners per row and column, and the side of a square in metres."""

    columns: int
    rows: int
    square_m: float

    def __post_init__(self) -> None:
        for name in ("columns", "rows"):
            value = getattr(self, name)
            # OpenCV's corner finder asserts on fewer than 3 (exit 3 for --board 2x2 until session 23)
            if not isinstance(value, int) or isinstance(value, bool) or value < 3:
                raise InvalidInputError(f"board {name} must be an integer >= 3 inner corners, got {value!r}")
        if not (isinstance(self.square_m, (int, float)) and 0 < self.square_m < 10):
            raise InvalidInputError(f"board square_m must be in (0, 10) metres, got {self.square_m!r}")

    @classmethod
    def parse(cls, text: str, square_m: float) -> Board:
        """``"9x6"`` (inner corners, columns x rows) and the square size in metres."""
        parts = text.lower().split("x")
        if len(parts) != 2 or not all(p.strip().isdigit() for p in parts):
            raise InvalidInputError(f"board must be COLUMNSxROWS of inner corners like 9x6, got {text!r}")
        return cls(int(parts[0]), int(parts[1]), float(square_m))

    def object_points(self) -> np.ndarray:
        """``float32 (columns * rows, 3)`` corner positions on the board plane, metres."""
        xs, ys = np.meshgrid(np.arange(self.columns), np.arange(self.rows))
        points = np.c_[xs.ravel(), ys.ravel(), np.zeros(xs.size)] * self.square_m
        return points.astype(np.float32)


def find_board(image: np.ndarray, board: Board) -> np.ndarray | None:
    """Inner corners of ``board`` in a grey or RGB ``uint8`` image, ``float32 (N, 2)``, or ``None``."""
    import cv2

    grey = cv2.cvtColor(image, cv2.COLOR_RGB2GRAY) if image.ndim == 3 else image
    size = (board.columns, board.rows)
    found, corners = cv2.findChessboardCorners(
        grey, size, flags=cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE)
    if found:
        criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 50, 1e-3)
        corners = cv2.cornerSubPix(grey, corners, (11, 11), (-1, -1), criteria)
    else:
        found, corners = cv2.findChessboardCornersSB(grey, size, flags=cv2.CALIB_CB_EXHAUSTIVE)
        if not found:
            return None
    return corners.reshape(-1, 2).astype(np.float32)


def _same_order(left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """``right`` listed in the order of ``left`` (a board's two corner orders differ by a half turn)."""
    reversed_right = right[::-1]
    if np.abs(left - reversed_right).sum() < np.abs(left - right).sum():
        return np.ascontiguousarray(reversed_right)
    return right


@dataclass(frozen=True, eq=False)
class ChessboardCalibration:
    """Result of :func:`calibrate_pairs`.

    Attributes
    ----------
    calibration : CameraPairCalibration
        The pair's calibration (translation in metres, ``rms_px`` set).
    rectification : Rectification
        The rectification it implies.
    rms_px : float
        RMS reprojection error of ``cv2.stereoCalibrate``, pixels.
    rms_left_px, rms_right_px : float
        RMS reprojection errors of the single-camera calibrations, pixels.
    epipolar : VerticalOffsetStats
        Vertical offsets of corresponding corners after rectification, pixels.
    used, rejected : tuple of str
        Names of the pairs used, and of those rejected with the reason.
    """

    calibration: CameraPairCalibration
    rectification: Rectification
    rms_px: float
    rms_left_px: float
    rms_right_px: float
    epipolar: VerticalOffsetStats
    used: tuple[str, ...]
    rejected: tuple[str, ...]

    def to_dict(self) -> dict:
        """JSON-ready report (without the matrices)."""
        return {"rms_px": self.rms_px, "rms_left_px": self.rms_left_px, "rms_right_px": self.rms_right_px,
                "epipolar_error_after_rectification": self.epipolar.to_dict(),
                "baseline_m": self.calibration.baseline_m, "rectified": self.rectification.rectified.to_dict(),
                "pairs_used": list(self.used), "pairs_rejected": list(self.rejected)}


def calibrate_pairs(pairs: list[tuple[str, np.ndarray, np.ndarray]], board: Board) -> ChessboardCalibration:
    """Calibrate a stereo rig from chessboard pairs.

    Parameters
    ----------
    pairs : list of (name, left, right)
        Images of the board seen by both cameras (grey or RGB ``uint8``, one size); ``name``
        identifies the pair in the report.
    board : Board
        Inner-corner counts and square size (metres: the translation comes out in metres).

    Returns
    -------
    ChessboardCalibration

    Raises
    ------
    CalibrationError
        Fewer than :data:`MIN_PAIRS` pairs show the board in both images, or the stereo
        reprojection error is above :data:`MAX_STEREO_RMS_FRACTION` of the image diagonal.
    ImageMismatchError
        The images are not all one size.
    """
    import cv2

    if not pairs:
        raise InvalidInputError("pairs: no image pairs given")
    size = pairs[0][1].shape[:2]
    found_left, found_right, used, rejected = [], [], [], []
    for name, left, right in pairs:
        if left.shape[:2] != size or right.shape[:2] != size:
            raise ImageMismatchError(f"pair {name}: images must all be {size[1]}x{size[0]}, got "
                                     f"{left.shape[1]}x{left.shape[0]} and {right.shape[1]}x{right.shape[0]}")
        corners_left, corners_right = find_board(left, board), find_board(right, board)
        missing = [side for side, c in (("left", corners_left), ("right", corners_right)) if c is None]
        if missing:
            rejected.append(f"{name} (board not found in the {' and '.join(missing)} image)")
            logger.warning("pair %s rejected: board not found in the %s image", name, " and ".join(missing))
            continue
        found_left.append(corners_left)
        found_right.append(_same_order(corners_left, corners_right))
        used.append(name)
    if len(used) < MIN_PAIRS:
        raise CalibrationError(f"the {board.columns}x{board.rows} board was found in both images of only "
                               f"{len(used)} pairs (need {MIN_PAIRS}); rejected: {'; '.join(rejected) or 'none'}")
    objects = [board.object_points()] * len(used)
    image_size = (size[1], size[0])
    rms_left, k_left, d_left, _, _ = cv2.calibrateCamera(objects, found_left, image_size, None, None)
    rms_right, k_right, d_right, _, _ = cv2.calibrateCamera(objects, found_right, image_size, None, None)
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 100, 1e-6)
    rms, k_left, d_left, k_right, d_right, rotation, translation, _, _ = cv2.stereoCalibrate(
        objects, found_left, found_right, k_left, d_left, k_right, d_right, image_size,
        criteria=criteria, flags=cv2.CALIB_USE_INTRINSIC_GUESS)
    diagonal = float(np.hypot(*image_size))
    if not rms <= MAX_STEREO_RMS_FRACTION * diagonal:
        raise CalibrationError(f"the boards do not fit one rig: stereo reprojection error {rms:.1f} px over "
                               f"{len(used)} pairs, {100 * rms / diagonal:.2f} % of the image diagonal (a good "
                               f"calibration stays below 0.1 %); check that the board size {board.columns}x"
                               f"{board.rows} counts the inner corners, and that each pair was taken at one moment")
    calibration = CameraPairCalibration(
        camera_matrix_left=k_left, distortion_left=d_left, camera_matrix_right=k_right, distortion_right=d_right,
        rotation=rotation, translation_m=translation.ravel(), width_px=image_size[0], height_px=image_size[1],
        rms_px=float(rms))
    rectification = rectify_calibration(calibration)
    epipolar = vertical_offset_stats(rectification.left_points(np.concatenate(found_left)),
                                     rectification.right_points(np.concatenate(found_right)))
    logger.info("stereo calibration: RMS %.3f px over %d pairs; after rectification %s", rms, len(used),
                epipolar.describe())
    return ChessboardCalibration(calibration=calibration, rectification=rectification, rms_px=float(rms),
                                 rms_left_px=float(rms_left), rms_right_px=float(rms_right), epipolar=epipolar,
                                 used=tuple(used), rejected=tuple(rejected))
