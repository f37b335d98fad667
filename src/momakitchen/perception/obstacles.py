"""Obstacle points from a depth frame: what a costmap's obstacle layer marks.

A base plans on a prior map of the room (walls, fixed furniture); things standing on the
floor that the map does not hold enter its obstacle layer as the depth camera sees them
(:meth:`momakitchen.sim.motion.FreeSpace.observe`), as in ROS 2 Nav2's obstacle layer,
which keeps points between a minimum and a maximum obstacle height within a maximum
range.
"""

from __future__ import annotations

import numpy as np

from momakitchen.errors import MomaError
from momakitchen.perception.camera import Intrinsics
from momakitchen.perception.clouds import cloud_in_base

# Nav2's obstacle layer keeps points up to its obstacle_max_range (2.5 m by default); a
# depth camera's error grows with the square of the depth, so points farther than this
# are left to a later, closer look.
MAX_RANGE = 4.0


def obstacle_points(
    depth: np.ndarray,
    intrinsics: Intrinsics,
    camera_to_base: np.ndarray,
    *,
    min_height: float = 0.05,
    max_height: float = 2.0,
    max_range: float = MAX_RANGE,
    exclude_mask: np.ndarray | None = None,
) -> np.ndarray:
    """Floor-plane positions of the depth points that stand above the floor.

    Every pixel with a valid depth (0 < depth <= ``max_range``, along the optical axis;
    0, NaN and inf are invalid) is back-projected and moved into the robot base frame
    (:func:`~momakitchen.perception.clouds.cloud_in_base`); the points with
    ``min_height < z < max_height`` (the floor is z = 0: ``min_height`` leaves the floor's
    noise out, ``max_height`` what the base passes under) are kept, without the pixels of
    ``exclude_mask`` (the target: what the base approaches is no obstacle to it).

    Args:
        depth: metres along the optical axis, possibly corrupted.
        intrinsics: the depth image's intrinsics.
        camera_to_base: camera to robot base frame (OpenCV camera axes).

    Shapes: ``depth`` (H, W); ``camera_to_base`` (4, 4); ``exclude_mask`` (H, W) bool or
    None; returns (M, 2) float64 base-frame xy, in pixel order.
    """
    if not (0 <= min_height < max_height):
        raise MomaError(
            f"obstacle heights need 0 <= min_height < max_height, got {min_height}, {max_height}"
        )
    if not max_range > 0:
        raise MomaError(f"max_range must be positive, got {max_range}")
    tf = np.asarray(camera_to_base, np.float64)
    if tf.shape != (4, 4) or not np.isfinite(tf).all():
        raise MomaError(f"camera_to_base must be a finite (4, 4) transform, got {tf.shape}")
    points, idx = cloud_in_base(np.asarray(depth), intrinsics, tf, max_range)
    keep = (points[:, 2] > min_height) & (points[:, 2] < max_height)
    if exclude_mask is not None:
        mask = np.asarray(exclude_mask, bool)
        if mask.shape != np.shape(depth):
            raise MomaError(
                f"exclude_mask shape {mask.shape} does not match the depth's {np.shape(depth)}"
            )
        keep &= ~mask.reshape(-1)[idx]
    return np.ascontiguousarray(points[keep, :2])
