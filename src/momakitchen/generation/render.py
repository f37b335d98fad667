"""Rendering a simulated head camera with PyBullet's TinyRenderer."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from momakitchen.bullet import p
from momakitchen.errors import MomaError
from momakitchen.perception.camera import Intrinsics


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


def render(
    client: int,
    camera_to_world: np.ndarray,
    intrinsics: Intrinsics,
    near: float = 0.05,
    far: float = 10.0,
    shadows: bool = False,
) -> Render:
    """Render RGB, metric depth and segmentation from a camera pose (OpenCV axes).

    Shadows look nicer but double TinyRenderer's time; datasets render without them.
    """
    w, h = intrinsics.width, intrinsics.height
    if intrinsics != Intrinsics.for_renderer(w, h, intrinsics.fov_y_deg):
        raise MomaError(
            "render() needs Intrinsics.for_renderer(...) (square pixels, the "
            f"renderer's principal point), got {intrinsics}"
        )
    eye = camera_to_world[:3, 3]
    forward, down = camera_to_world[:3, 2], camera_to_world[:3, 1]
    view = p.computeViewMatrix(eye.tolist(), (eye + forward).tolist(), (-down).tolist())
    proj = p.computeProjectionMatrixFOV(intrinsics.fov_y_deg, w / h, near, far)
    _, _, rgba, zbuf, seg = p.getCameraImage(
        w,
        h,
        view,
        proj,
        renderer=p.ER_TINY_RENDERER,
        shadow=int(shadows),
        lightDirection=[0.4, 0.8, 2.0],
        flags=p.ER_SEGMENTATION_MASK_OBJECT_AND_LINKINDEX,
        physicsClientId=client,
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
