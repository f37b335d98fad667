"""Where a robot's base fits, from the points a view shows above the floor.

The one test the classical base placement methods (``placement/``) and a model's footprint
gate (``ModelConfig.footprint_gate``) place by: the base's box, centred on a floor point
and turned to face the target, may hold none of the view's points between
:data:`OBSTACLE_MIN_Z` and the arm's mount, after a radius outlier filter
(:func:`supported`), as a costmap's point cloud is filtered before marking.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

# Points this high above the fitted floor (m) are obstacles: above the floor noise a
# frame's floor points are put on the plane from (perception.floor), and below any bumper.
OBSTACLE_MIN_Z = 0.03
# Clearance (m) kept around the base's box, as generation keeps around its viewpoints.
FOOTPRINT_MARGIN = 0.02
# Obstacle points are merged on this grid (m) before the footprint test: a wall's column
# of points blocks the floor as one.
OBSTACLE_GRID = 0.02
# A point above the floor is an obstacle only with this many others within
# OBSTACLE_RADIUS (m): a radius outlier filter, as a costmap's point cloud is filtered
# before marking. A real surface seen through 2 cm voxels has many neighbours at any
# range; a stereo sensor's far floor noise and flying pixels at depth edges stand alone.
# Chosen on development scenes (docs/PLACEMENT.md, "Design"): 4 and 8 did equally well
# there, 0 (no filter) worse; the smaller keeps more of a thin obstacle.
OBSTACLE_NEIGHBOURS = 4
OBSTACLE_RADIUS = 0.05


def supported(points: np.ndarray) -> np.ndarray:
    """The points with at least :data:`OBSTACLE_NEIGHBOURS` others within
    :data:`OBSTACLE_RADIUS`. Shapes: (M, 3) -> (K, 3), K <= M, in input order."""
    if len(points) == 0:
        return points
    counts = cKDTree(points).query_ball_point(points, OBSTACLE_RADIUS, return_length=True)
    return points[counts > OBSTACLE_NEIGHBOURS]


def footprint_free(
    floor_xyz: np.ndarray,
    points: np.ndarray,
    target_xyz: np.ndarray,
    footprint: tuple[float, float],
    ceiling: float,
) -> np.ndarray:
    """:func:`free_floor` on arrays: floor points ``floor_xyz`` (N, 3), obstacle points
    ``points`` (M, 3) (the frame's points off the floor, filtered by :func:`supported`),
    the target ``target_xyz`` (3,) the base faces. Shapes: -> (N,) bool."""
    floor = floor_xyz[:, :2]
    pts = points[points[:, 2] <= ceiling, :2]
    free = np.ones(len(floor), bool)
    if len(pts) == 0 or len(floor) == 0:
        return free
    pts = np.unique(np.floor(pts / OBSTACLE_GRID), axis=0) * OBSTACLE_GRID + OBSTACLE_GRID / 2
    half_l = footprint[0] / 2 + FOOTPRINT_MARGIN
    half_w = footprint[1] / 2 + FOOTPRINT_MARGIN
    # Candidates within the box's circumscribed circle, then the box itself.
    pairs = cKDTree(floor).sparse_distance_matrix(
        cKDTree(pts), math.hypot(half_l, half_w), output_type="ndarray"
    )
    i, j = pairs["i"], pairs["j"]
    to = target_xyz[:2] - floor
    u = to / np.maximum(np.hypot(to[:, 0], to[:, 1]), 1e-9)[:, None]
    rel = pts[j] - floor[i]
    along = rel[:, 0] * u[i, 0] + rel[:, 1] * u[i, 1]
    across = -rel[:, 0] * u[i, 1] + rel[:, 1] * u[i, 0]
    inside = (np.abs(along) <= half_l) & (np.abs(across) <= half_w)
    free[np.unique(i[inside])] = False
    return free


def base_obstacles(global_xyz: np.ndarray) -> np.ndarray:
    """A view's points that may block a base: above :data:`OBSTACLE_MIN_Z`, kept by
    :func:`supported`. Shapes: (N, 3) -> (K, 3) float64."""
    pts = np.asarray(global_xyz, np.float64)
    return supported(pts[pts[:, 2] > OBSTACLE_MIN_Z])
