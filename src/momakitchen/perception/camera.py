"""Pinhole cameras rendered with PyBullet's CPU renderer (TinyRenderer)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pybullet as p


@dataclass(frozen=True)
class Intrinsics:
    """Pinhole intrinsics in pixels for an image of ``width`` x ``height``."""

    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int

    @classmethod
    def from_fov(cls, width: int, height: int, fov_y_deg: float) -> Intrinsics:
        """Square pixels, principal point at the image centre, vertical field of view."""
        f = 0.5 * height / np.tan(np.deg2rad(fov_y_deg) / 2)
        return cls(f, f, width / 2, height / 2, width, height)

    @property
    def fov_y_deg(self) -> float:
        return float(np.rad2deg(2 * np.arctan(0.5 * self.height / self.fy)))


@dataclass(frozen=True)
class Render:
    """One rendered frame.

    Shapes: ``rgb`` (H, W, 3) uint8; ``depth`` (H, W) float32 metric distance along the
    optical axis (m); ``segmentation`` (H, W) int32 body id (-1 = background).
    """

    rgb: np.ndarray
    depth: np.ndarray
    segmentation: np.ndarray


def render(
    client: int,
    eye: np.ndarray,
    target: np.ndarray,
    intrinsics: Intrinsics,
    near: float = 0.05,
    far: float = 12.0,
    up: tuple[float, float, float] = (0.0, 0.0, 1.0),
) -> Render:
    """Render RGB, metric depth and segmentation from ``eye`` looking at ``target``."""
    w, h = intrinsics.width, intrinsics.height
    view = p.computeViewMatrix(list(map(float, eye)), list(map(float, target)), list(up))
    proj = p.computeProjectionMatrixFOV(intrinsics.fov_y_deg, w / h, near, far)
    _, _, rgba, zbuf, seg = p.getCameraImage(
        w, h, view, proj, renderer=p.ER_TINY_RENDERER, shadow=1,
        lightDirection=[0.4, 0.8, 2.0], physicsClientId=client,
    )
    rgba = np.asarray(rgba, dtype=np.uint8).reshape(h, w, 4)
    zbuf = np.asarray(zbuf, dtype=np.float64).reshape(h, w)
    # OpenGL depth buffer in [0, 1] to metric depth along the optical axis.
    depth = (far * near / (far - (far - near) * zbuf)).astype(np.float32)
    seg = np.asarray(seg, dtype=np.int32).reshape(h, w)
    return Render(rgba[..., :3].copy(), depth, seg)
