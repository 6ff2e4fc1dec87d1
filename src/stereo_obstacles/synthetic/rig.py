"""The synthetic pinhole stereo rig: intrinsics, pose above the ground, and camera rays.

Camera frame (OpenCV): ``X`` right, ``Y`` down, ``Z`` forward along the optical axis. The
left camera sits at world ``(0, forward_m, camera_height_m)`` looking along world ``+y``,
pitched down by ``pitch_deg``; the right camera is ``baseline_m`` further along the left
camera's ``X`` axis (world ``+x``: the pitch turns about that axis), so the pair is rectified
by construction. A :class:`RightCameraError` rotates the right camera slightly and shifts its
image vertically, which the rectification stage must later undo.

A pixel ``(u, v)`` (column, row; integer values at pixel centres) looks along the camera
direction ``((u - cx) / f, (v - cy) / f, 1)``. Because that vector has unit ``Z``, the ray
parameter ``t`` of a hit equals the hit's depth ``Z`` in that camera.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import plain_numbers, python_number


def _check_number(name: str, value: float, lo: float, hi: float) -> None:
    if not (isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
            and lo <= value <= hi):
        raise InvalidInputError(f"{name} must be a number in [{lo}, {hi}], got {value!r}")


@dataclass(frozen=True)
class StereoRig:
    """A rectified pinhole stereo pair standing above the ground.

    Attributes
    ----------
    width_px, height_px : int
        Image size in pixels.
    focal_px : float
        Focal length in pixels (the same for both cameras and both axes).
    baseline_m : float
        Distance between the optical centres in metres.
    camera_height_m : float
        Height of the optical centres above the ground in metres.
    pitch_deg : float
        Downward tilt of the optical axes from horizontal in degrees (positive looks down).
    cx_px, cy_px : float
        Principal point in pixels; ``None`` means the image centre.
    """

    width_px: int
    height_px: int
    focal_px: float
    baseline_m: float = 0.12
    camera_height_m: float = 1.2
    pitch_deg: float = 12.0
    cx_px: float | None = None
    cy_px: float | None = None

    def __post_init__(self) -> None:
        plain_numbers(self)                      # NumPy scalars as Python numbers (JSON-ready)
        for name in ("width_px", "height_px"):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool) or not 16 <= value <= 8192:
                raise InvalidInputError(f"rig {name} must be an integer in [16, 8192], got {value!r}")
        _check_number("rig focal_px", self.focal_px, 1.0, 1e5)
        _check_number("rig baseline_m", self.baseline_m, 1e-3, 10.0)
        _check_number("rig camera_height_m", self.camera_height_m, 0.05, 100.0)
        _check_number("rig pitch_deg", self.pitch_deg, -45.0, 80.0)
        if self.cx_px is None:
            object.__setattr__(self, "cx_px", (self.width_px - 1) / 2.0)
        if self.cy_px is None:
            object.__setattr__(self, "cy_px", (self.height_px - 1) / 2.0)
        _check_number("rig cx_px", self.cx_px, -self.width_px, 2.0 * self.width_px)
        _check_number("rig cy_px", self.cy_px, -self.height_px, 2.0 * self.height_px)

    @classmethod
    def with_field_of_view(cls, width_px: int, height_px: int, *, hfov_deg: float = 60.0,
                           **kwargs: float) -> StereoRig:
        """A rig whose focal length gives the horizontal field of view ``hfov_deg``."""
        _check_number("hfov_deg", hfov_deg, 1.0, 170.0)
        focal = (width_px / 2.0) / math.tan(math.radians(hfov_deg) / 2.0)
        return cls(width_px=width_px, height_px=height_px, focal_px=focal, **kwargs)

    def calibration(self) -> StereoCalibration:
        """The rectified calibration of the pair (what a perfect calibration would report)."""
        return StereoCalibration(focal_px=float(self.focal_px), cx_px=float(self.cx_px),
                                 cy_px=float(self.cy_px), baseline_m=float(self.baseline_m),
                                 width_px=self.width_px, height_px=self.height_px)

    def intrinsic_matrix(self) -> np.ndarray:
        """The ``(3, 3)`` camera matrix ``K`` of the (rectified) cameras."""
        return np.array([[self.focal_px, 0.0, self.cx_px], [0.0, self.focal_px, self.cy_px],
                         [0.0, 0.0, 1.0]])

    def world_from_camera(self) -> np.ndarray:
        """``(3, 3)`` rotation whose columns are the left camera's X, Y, Z axes in world frame."""
        p = math.radians(self.pitch_deg)
        x_axis = np.array([1.0, 0.0, 0.0])
        z_axis = np.array([0.0, math.cos(p), -math.sin(p)])
        y_axis = np.cross(z_axis, x_axis)
        return np.stack([x_axis, y_axis, z_axis], axis=1)

    def left_centre(self, forward_m: float = 0.0) -> np.ndarray:
        """World position of the left optical centre when the rig has moved ``forward_m``."""
        return np.array([0.0, forward_m, self.camera_height_m])

    def right_centre(self, forward_m: float = 0.0) -> np.ndarray:
        """World position of the right optical centre."""
        return self.left_centre(forward_m) + self.baseline_m * self.world_from_camera()[:, 0]

    def horizon_row_px(self) -> float:
        """Image row of the horizon (rays parallel to the ground)."""
        return float(self.cy_px - self.focal_px * math.tan(math.radians(self.pitch_deg)))

    def ground_depth_m(self, v: np.ndarray) -> np.ndarray:
        """Depth ``Z`` of the ground plane seen at image row ``v`` (``+inf`` above the horizon).

        Depends on the row only: a ray through row ``v`` falls by
        ``sin(p) + cos(p) (v - cy) / f`` metres per metre of depth.
        """
        p = math.radians(self.pitch_deg)
        fall = math.sin(p) + math.cos(p) * (np.asarray(v, dtype=np.float64) - self.cy_px) / self.focal_px
        with np.errstate(divide="ignore"):
            return np.where(fall > 0, self.camera_height_m / np.where(fall > 0, fall, 1.0), np.inf)


def rotation_xyz(rotation_deg: tuple[float, float, float]) -> np.ndarray:
    """Rotation matrix ``Rx(a) @ Ry(b) @ Rz(c)`` for angles in degrees about camera X, Y, Z."""
    a, b, c = (math.radians(float(v)) for v in rotation_deg)
    rx = np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])
    ry = np.array([[math.cos(b), 0, math.sin(b)], [0, 1, 0], [-math.sin(b), 0, math.cos(b)]])
    rz = np.array([[math.cos(c), -math.sin(c), 0], [math.sin(c), math.cos(c), 0], [0, 0, 1]])
    return rx @ ry @ rz


@dataclass(frozen=True)
class RightCameraError:
    """A known mis-mounting of the right camera (zero by default: a rectified pair).

    Attributes
    ----------
    rotation_deg : tuple of 3 floats
        Rotation of the right camera relative to the rectified orientation, degrees about
        the camera X (tilt), Y (pan) and Z (roll) axes, composed as ``Rx @ Ry @ Rz``.
    vertical_offset_px : float
        Shift of the right principal point down the image, pixels (an image shifted down).
    """

    rotation_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    vertical_offset_px: float = 0.0

    def __post_init__(self) -> None:
        plain_numbers(self)                      # NumPy scalars as Python numbers (JSON-ready)
        if not isinstance(self.rotation_deg, (tuple, list, np.ndarray)):
            raise InvalidInputError(f"right camera rotation_deg needs 3 angles (degrees about x, y, z), got "
                                    f"{self.rotation_deg!r}")
        rot = tuple(python_number(angle) for angle in self.rotation_deg)      # an array's are NumPy numbers
        if len(rot) != 3:
            raise InvalidInputError(f"right camera rotation_deg needs 3 angles, got {len(rot)}")
        for angle in rot:
            _check_number("right camera rotation angle (degrees)", angle, -10.0, 10.0)
        object.__setattr__(self, "rotation_deg", tuple(float(a) for a in rot))
        _check_number("right camera vertical_offset_px", self.vertical_offset_px, -100.0, 100.0)

    @property
    def is_zero(self) -> bool:
        """True when the right camera is exactly rectified."""
        return self.rotation_deg == (0.0, 0.0, 0.0) and self.vertical_offset_px == 0.0

    def left_from_right(self) -> np.ndarray:
        """``(3, 3)`` rotation whose columns are the right camera axes in the left camera frame."""
        return rotation_xyz(self.rotation_deg)

    def right_intrinsic_matrix(self, rig: StereoRig) -> np.ndarray:
        """The true camera matrix of the right camera."""
        k = rig.intrinsic_matrix()
        k[1, 2] += self.vertical_offset_px
        return k

    def extrinsics(self, rig: StereoRig) -> tuple[np.ndarray, np.ndarray]:
        """OpenCV stereo extrinsics ``(R, T)``: a left-camera point ``X`` is ``R @ X + T`` in the right."""
        r = self.left_from_right().T
        t = -r @ np.array([rig.baseline_m, 0.0, 0.0])
        return r, t


@dataclass(frozen=True)
class CameraPose:
    """Where one camera is and how it looks: centre, world-from-camera rotation, intrinsics."""

    centre: np.ndarray
    world_from_camera: np.ndarray
    intrinsics: np.ndarray
    width_px: int
    height_px: int

    def ray_directions(self, supersample: int = 1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """World ray directions ``(H*s, W*s)`` for an ``s x s`` grid of samples in each pixel.

        Samples sit at ``(i + 0.5) / s - 0.5`` pixels from the pixel centre; the camera-frame
        direction has unit ``Z``, so ``t`` along these rays is camera depth.
        """
        s = supersample
        offsets = (np.arange(s) + 0.5) / s - 0.5
        u = (np.arange(self.width_px)[:, None] + offsets[None, :]).reshape(-1)
        v = (np.arange(self.height_px)[:, None] + offsets[None, :]).reshape(-1)
        k_inv = np.linalg.inv(self.intrinsics)
        xc = k_inv[0, 0] * u[None, :] + k_inv[0, 1] * v[:, None] + k_inv[0, 2]
        yc = k_inv[1, 1] * v[:, None] + k_inv[1, 2] + 0.0 * u[None, :]
        r = self.world_from_camera
        return tuple(r[i, 0] * xc + r[i, 1] * yc + r[i, 2] for i in range(3))

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pixel coordinates ``(u, v)`` and depth ``Z`` of world points ``(N, 3)``."""
        p = np.asarray(points, dtype=np.float64)
        return self.project_xyz(p[:, 0], p[:, 1], p[:, 2])

    def project_xyz(self, x: np.ndarray, y: np.ndarray, z: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`project` for points given as three component arrays of any shape."""
        r = self.world_from_camera
        k = self.intrinsics
        rel = (x - self.centre[0], y - self.centre[1], z - self.centre[2])
        xc, yc, zc = (rel[0] * r[0, i] + rel[1] * r[1, i] + rel[2] * r[2, i] for i in range(3))
        with np.errstate(divide="ignore", invalid="ignore"):
            u = (k[0, 0] * xc + k[0, 1] * yc) / zc + k[0, 2]
            v = k[1, 1] * yc / zc + k[1, 2]
        return u, v, zc


def camera_poses(rig: StereoRig, error: RightCameraError, forward_m: float = 0.0
                 ) -> tuple[CameraPose, CameraPose, CameraPose]:
    """The left camera, the true right camera and the ideal rectified right camera."""
    r_wc = rig.world_from_camera()
    k = rig.intrinsic_matrix()
    left = CameraPose(rig.left_centre(forward_m), r_wc, k, rig.width_px, rig.height_px)
    right_rectified = CameraPose(rig.right_centre(forward_m), r_wc, k, rig.width_px, rig.height_px)
    right = CameraPose(rig.right_centre(forward_m), r_wc @ error.left_from_right(),
                       error.right_intrinsic_matrix(rig), rig.width_px, rig.height_px)
    return left, right, right_rectified
