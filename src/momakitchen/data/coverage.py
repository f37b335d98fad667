"""Does a view see where to stand? Floor points near given world positions (the
successful trial positions): the check of view sampling, the dataset's coverage counts
and the label audit all use these."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from momakitchen.frames import base_to_world_xy

# A view "covers" its configuration if its floor comes this close to a success (m).
COVERAGE_RADIUS = 0.10


def near_any(points: np.ndarray, targets: np.ndarray, radius: float) -> np.ndarray:
    """Which of ``points`` (N, 2) lie within ``radius`` of one of ``targets`` (M, 2);
    (N,) bool."""
    points = np.asarray(points, np.float64).reshape(-1, 2)
    targets = np.asarray(targets, np.float64).reshape(-1, 2)
    if len(points) == 0 or len(targets) == 0:
        return np.zeros(len(points), bool)
    from scipy.spatial import cKDTree

    dist, _ = cKDTree(targets).query(points, k=1, distance_upper_bound=radius + 1e-9)
    return np.isfinite(dist)


def sees_near(
    floor: np.ndarray,
    base: Sequence[float],
    points: np.ndarray,
    radius: float = COVERAGE_RADIUS,
) -> bool:
    """Whether floor points (N, 3) or (N, 2) in the base frame of the viewpoint ``base``
    = (x, y, yaw) come within ``radius`` of one of the world ``points`` (M, 2)."""
    if len(floor) == 0 or len(points) == 0:
        return False
    world = base_to_world_xy(np.asarray(floor)[:, :2], base)
    return bool(near_any(world, points, radius).any())
