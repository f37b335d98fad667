"""Pinhole cameras rendered with PyBullet's CPU renderer (TinyRenderer), and the geometry
between pixels, camera frames and robot base frames.

Camera frames and intrinsics follow the OpenCV convention: x right, y down, z forward
(optical axis); pixel ``(row, col)`` has its centre at ``u = col``, ``v = row``, as in the
intrinsics that RGB-D cameras (e.g. RealSense) report.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pybullet as p

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
        if not (self.fx > 0 and self.fy > 0 and np.isfinite([self.fx, self.fy, self.cx,
                                                              self.cy]).all()):
            raise MomaError(f"focal lengths must be positive and finite, got fx={self.fx}, "
                            f"fy={self.fy}, cx={self.cx}, cy={self.cy}")

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


@dataclass(frozen=True)
class Render:
    """One rendered frame.

    Shapes: ``rgb`` (H, W, 3) uint8; ``depth`` (H, W) float32 metric distance along the
    optical axis (m; 0 where nothing was hit); ``body`` (H, W) int32 body id (-1 =
    background); ``link`` (H, W) int32 link index (-1 = base).
    """

    rgb: np.ndarray
    depth: np.ndarray
    body: np.ndarray
    link: np.ndarray


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


def render(client: int, camera_to_world: np.ndarray, intrinsics: Intrinsics,
           near: float = 0.05, far: float = 10.0, shadows: bool = False) -> Render:
    """Render RGB, metric depth and segmentation from a camera pose (OpenCV axes).

    Shadows look nicer but double TinyRenderer's time; datasets render without them.
    """
    w, h = intrinsics.width, intrinsics.height
    if intrinsics != Intrinsics.for_renderer(w, h, intrinsics.fov_y_deg):
        raise MomaError("render() needs Intrinsics.for_renderer(...) (square pixels, the "
                        f"renderer's principal point), got {intrinsics}")
    eye = camera_to_world[:3, 3]
    forward, down = camera_to_world[:3, 2], camera_to_world[:3, 1]
    view = p.computeViewMatrix(eye.tolist(), (eye + forward).tolist(), (-down).tolist())
    proj = p.computeProjectionMatrixFOV(intrinsics.fov_y_deg, w / h, near, far)
    _, _, rgba, zbuf, seg = p.getCameraImage(
        w, h, view, proj, renderer=p.ER_TINY_RENDERER, shadow=int(shadows),
        lightDirection=[0.4, 0.8, 2.0],
        flags=p.ER_SEGMENTATION_MASK_OBJECT_AND_LINKINDEX, physicsClientId=client,
    )
    rgba = np.asarray(rgba, dtype=np.uint8).reshape(h, w, 4)
    zbuf = np.asarray(zbuf, dtype=np.float64).reshape(h, w)
    # OpenGL depth buffer in [0, 1] to metric depth along the optical axis.
    depth = far * near / (far - (far - near) * zbuf)
    depth = np.where(zbuf >= 1.0 - 1e-7, 0.0, depth).astype(np.float32)
    seg = np.asarray(seg, dtype=np.int64).reshape(h, w)
    body = np.where(seg >= 0, seg & ((1 << 24) - 1), -1).astype(np.int32)
    link = np.where(seg >= 0, (seg >> 24) - 1, -1).astype(np.int32)
    return Render(rgba[..., :3].copy(), depth, body, link)


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
        raise MomaError(f"depth shape {depth.shape} does not match the intrinsics "
                        f"({intrinsics.height}, {intrinsics.width})")


def backproject_into(flat_depth: np.ndarray, idx: np.ndarray, intrinsics: Intrinsics,
                     out: np.ndarray) -> None:
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
    return np.stack([intrinsics.fx * pts[:, 0] / pts[:, 2] + intrinsics.cx,
                     intrinsics.fy * pts[:, 1] / pts[:, 2] + intrinsics.cy], axis=1)


def transform(tf: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Apply a (4, 4) rigid transform to points. Shapes: (N, 3) -> (N, 3).

    Written as three multiply-adds per axis: a BLAS matrix product on an (N, 3) array
    costs 15x more CPU here (its threads spin on a busy machine). The result is a
    transposed (3, N) array, so each coordinate is contiguous; with such an input (as
    :func:`backproject` returns) every operation runs on contiguous memory.
    """
    pts = np.asarray(points, float).T
    out = np.empty((3, pts.shape[1]))
    transform_into(tf, pts, out)
    return out.T


def transform_into(tf: np.ndarray, rows: np.ndarray, out: np.ndarray) -> None:
    """Apply a (4, 4) rigid transform to points given as rows (3, n) x, y, z, writing the
    rows of the result into ``out`` (3, n):
    ``out[i] = x * tf[i, 0] + y * tf[i, 1] + z * tf[i, 2] + tf[i, 3]``, in that order,
    in place."""
    tmp = np.empty(rows.shape[1])
    for i, o in enumerate(out):
        np.multiply(rows[0], tf[i, 0], out=o)
        for j in (1, 2):
            np.multiply(rows[j], tf[i, j], out=tmp)
            o += tmp
        o += tf[i, 3]


def base_to_world(base: tuple[float, float, float]) -> np.ndarray:
    """Transform (4, 4) of a robot base frame at ``(x, y, yaw)`` on the floor."""
    x, y, yaw = base
    tf = np.eye(4)
    c, s = np.cos(yaw), np.sin(yaw)
    tf[:2, :2] = [[c, -s], [s, c]]
    tf[:2, 3] = [x, y]
    return tf
