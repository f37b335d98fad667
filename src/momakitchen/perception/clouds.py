"""Point clouds from RGB-D frames: back-projection, base frame, voxel down-sampling."""

from __future__ import annotations

import numpy as np

from momakitchen.perception.camera import Intrinsics, backproject, transform


def voxel_downsample(points: np.ndarray, voxel: float) -> np.ndarray:
    """Indices of one representative point per occupied voxel (deterministic: the first
    point, in input order, of each voxel; returned sorted).

    Shapes: ``points`` (N, 3) -> indices (M,) with M <= N.
    """
    if len(points) == 0 or voxel <= 0:
        return np.arange(len(points))
    cells = np.floor(points / voxel).astype(np.int64)
    cells -= cells.min(axis=0)
    span = cells.max(axis=0) + 1
    # One integer key per voxel: a 1-D unique is far faster than unique over rows.
    keys = (cells[:, 0] * span[1] + cells[:, 1]) * span[2] + cells[:, 2]
    _, first = np.unique(keys, return_index=True)
    return np.sort(first)


def cloud_in_base(depth: np.ndarray, intrinsics: Intrinsics, camera_to_base: np.ndarray,
                  max_depth: float) -> tuple[np.ndarray, np.ndarray]:
    """Back-project valid pixels (0 < depth <= max_depth) into the robot base frame.

    Returns points (N, 3) float64 in the base frame and their flat pixel indices (N,).
    """
    d = np.where(depth <= max_depth, depth, 0.0)
    pts, idx = backproject(d, intrinsics)
    return transform(camera_to_base, pts), idx
