"""Pinhole cameras: intrinsics, the head camera's settings, and the geometry between pixels
and camera frames (pure geometry; rendering is in :mod:`momakitchen.generation.render`).

Camera frames and intrinsics follow the OpenCV convention: x right, y down, z forward
(optical axis); pixel ``(row, col)`` has its centre at ``u = col``, ``v = row``, as in the
intrinsics that RGB-D cameras (e.g. RealSense) report.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from momakitchen.errors import MomaError


@dataclass(frozen=True)
class Intrinsics:
    """Pinhole intrinsics in pixels for an image of ``width`` x ``height``."""

    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int

    def __post_init__(self) -> None:
        if not (self.width > 0 and self.height > 0):
            raise MomaError(f"image size must be positive, got {self.width} x {self.height}")
        if not (
            self.fx > 0 and self.fy > 0 and np.isfinite([self.fx, self.fy, self.cx, self.cy]).all()
        ):
            raise MomaError(
                f"focal lengths must be positive and finite, got fx={self.fx}, "
                f"fy={self.fy}, cx={self.cx}, cy={self.cy}"
            )

    @classmethod
    def from_fov(cls, width: int, height: int, fov_y_deg: float) -> Intrinsics:
        """Square pixels, principal point at the image centre, vertical field of view."""
        f = 0.5 * height / np.tan(np.deg2rad(fov_y_deg) / 2)
        return cls(f, f, width / 2, height / 2, width, height)

    @classmethod
    def for_renderer(cls, width: int, height: int, fov_y_deg: float) -> Intrinsics:
        """The intrinsics of images from :func:`render` (PyBullet's TinyRenderer).

        Its principal point sits at ``(W / 2, H / 2 - 1)`` in the OpenCV convention; this
        was measured by casting rays through pixel centres onto flat surfaces (residual
        < 0.01 mm, see ``tests/perception``), not taken from documentation.
        """
        f = 0.5 * height / np.tan(np.deg2rad(fov_y_deg) / 2)
        return cls(f, f, width / 2, height / 2 - 1, width, height)

    @property
    def fov_y_deg(self) -> float:
        return float(np.rad2deg(2 * np.arctan(0.5 * self.height / self.fy)))

    def as_array(self) -> np.ndarray:
        """``(fx, fy, cx, cy)``, shape (4,)."""
        return np.array([self.fx, self.fy, self.cx, self.cy])


def look_at(eye: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Camera-to-world transform (4, 4) of a camera at ``eye`` looking at ``target``,
    OpenCV axes, image rows aligned with the horizon (world z up)."""
    eye, target = np.asarray(eye, float), np.asarray(target, float)
    z = target - eye
    if np.linalg.norm(z) < 1e-9:
        raise MomaError("camera eye and target coincide")
    z /= np.linalg.norm(z)
    x = np.cross(z, [0.0, 0.0, 1.0])
    if np.linalg.norm(x) < 1e-6:
        raise MomaError("camera looks straight up or down: horizon undefined")
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    tf = np.eye(4)
    tf[:3, :3] = np.stack([x, y, z], axis=1)
    tf[:3, 3] = eye
    return tf


def look_toward(
    eye: np.ndarray, target: np.ndarray, intrinsics: Intrinsics, row: float
) -> np.ndarray:
    """Camera-to-world transform (4, 4) of a camera at ``eye`` turned toward ``target``
    (horizontally centred) and pitched so that ``target`` appears at image row
    ``row * height`` (0.5: the image centre, as :func:`look_at`; smaller values put the
    target higher and show more of the floor in front of it)."""
    eye, target = np.asarray(eye, float), np.asarray(target, float)
    d = target - eye
    horizontal = float(np.hypot(d[0], d[1]))
    if horizontal < 1e-6:
        raise MomaError("camera target straight above or below the eye: horizon undefined")
    below = np.arctan2(-d[2], horizontal)  # the target's angle below the horizon
    offset = np.arctan((0.5 - row) * intrinsics.height / intrinsics.fy)
    pitch = float(np.clip(below + offset, -np.pi / 2 + 0.05, np.pi / 2 - 0.05))
    yaw = np.arctan2(d[1], d[0])
    forward = np.array([np.cos(yaw) * np.cos(pitch), np.sin(yaw) * np.cos(pitch), -np.sin(pitch)])
    return look_at(eye, eye + forward)


def backproject(depth: np.ndarray, intrinsics: Intrinsics) -> tuple[np.ndarray, np.ndarray]:
    """Camera-frame points of every pixel with a valid depth.

    Invalid pixels (0, negative, NaN or inf) are skipped.

    Shapes: ``depth`` (H, W) metres; returns points (N, 3) float64 in the camera frame and
    the flat pixel indices (N,) they came from. The points are a transposed (3, N) array,
    so each coordinate is contiguous (see :func:`transform`).
    """
    check_depth_shape(depth, intrinsics)
    flat = depth.reshape(-1)
    idx = np.flatnonzero(np.isfinite(flat) & (flat > 0))
    out = np.empty((3, len(idx)))
    backproject_into(flat, idx, intrinsics, out)
    return out.T, idx


def check_depth_shape(depth: np.ndarray, intrinsics: Intrinsics) -> None:
    """Raise MomaError unless ``depth`` is (height, width) of ``intrinsics``."""
    if depth.shape != (intrinsics.height, intrinsics.width):
        raise MomaError(
            f"depth shape {depth.shape} does not match the intrinsics "
            f"({intrinsics.height}, {intrinsics.width})"
        )


def backproject_into(
    flat_depth: np.ndarray, idx: np.ndarray, intrinsics: Intrinsics, out: np.ndarray
) -> None:
    """Camera-frame coordinates of the pixels ``idx`` of a flattened depth image, written
    into ``out`` (3, n) as rows x, y, z: ``x = (u - cx) * z / fx``, likewise y.

    In place: fresh large temporaries cost a page fault per 4 kB.
    """
    v, u = np.divmod(idx, intrinsics.width)
    x, y, z = out
    z[:] = flat_depth[idx]
    np.subtract(u, intrinsics.cx, out=x)
    x *= z
    x /= intrinsics.fx
    np.subtract(v, intrinsics.cy, out=y)
    y *= z
    y /= intrinsics.fy


def project(points_cam: np.ndarray, intrinsics: Intrinsics) -> np.ndarray:
    """Pixel coordinates ``(u, v)`` of camera-frame points. Shapes: (N, 3) -> (N, 2)."""
    pts = np.asarray(points_cam, float)
    return np.stack(
        [
            intrinsics.fx * pts[:, 0] / pts[:, 2] + intrinsics.cx,
            intrinsics.fy * pts[:, 1] / pts[:, 2] + intrinsics.cy,
        ],
        axis=1,
    )


@dataclass(frozen=True)
class CameraConfig:
    """The viewing robot's head camera.

    Attributes:
        width, height: image size in pixels.
        fov_y_deg: vertical field of view (45 deg ~ a RealSense D435 colour camera).
        above_mount: camera height above the arm mount (the paper: mount height + 0.3 m).
        near, far: clipping planes (m); depth beyond ``max_depth`` is dropped from clouds.
    """

    width: int = 640
    height: int = 480
    fov_y_deg: float = 45.0
    above_mount: float = 0.3
    near: float = 0.05
    far: float = 10.0
    max_depth: float = 6.0

    def __post_init__(self) -> None:
        if not (16 <= self.width <= 4096 and 16 <= self.height <= 4096):
            raise MomaError(f"camera size must be 16..4096 px, got {self.width}x{self.height}")
        if not 10 <= self.fov_y_deg <= 120:
            raise MomaError(f"camera fov_y_deg must be in [10, 120], got {self.fov_y_deg}")
        if not 0 < self.near < self.max_depth <= self.far:
            raise MomaError(
                f"camera needs 0 < near < max_depth <= far, got near={self.near}, "
                f"max_depth={self.max_depth}, far={self.far}"
            )

    @property
    def intrinsics(self) -> Intrinsics:
        return Intrinsics.for_renderer(self.width, self.height, self.fov_y_deg)
