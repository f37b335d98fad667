"""What a classical method knows of the room: one RGB-D frame's floor, obstacles and target.

The frame is read as the learned path reads it (:func:`~momakitchen.perception.live.frame_inputs`:
the floor plane fitted to the frame, floor points put on it, the target the
depth-consistent part of its mask), and nothing else is assumed: the floor a base may stand
on is the floor the frame shows, free of the points it shows above the floor.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from momakitchen.errors import MomaError
from momakitchen.perception.floor import FloorCorrection
from momakitchen.perception.inputs import FrameArrays

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
# The target's points are a plane (a door, a drawer front) when they lie this close to it
# (m, standard deviation) and spread this far along both of its directions.
PLANE_THICKNESS = 0.01
PLANE_SPREAD = 0.03
# A surface facing up within this angle (deg) is a top: approached from above.
TOP_ANGLE = 30.0


@dataclass(frozen=True)
class ObservedFrame:
    """A frame as the classical methods see it, in the (floor-corrected) base frame.

    Shapes: ``floor_xyz`` (N, 3) the visible floor (z = 0); ``points`` (M, 3) the
    frame's points off the floor (voxel-thinned); ``target_points`` (T, 3);
    ``target_xyz`` (3,) the median of the target's depth-consistent points;
    ``camera_xyz`` (3,) the camera's position; ``correction`` the floor correction.
    """

    floor_xyz: np.ndarray
    points: np.ndarray
    target_points: np.ndarray
    target_xyz: np.ndarray
    camera_xyz: np.ndarray
    correction: FloorCorrection

    def __post_init__(self) -> None:
        for name in ("floor_xyz", "points", "target_points"):
            arr = getattr(self, name)
            if arr.ndim != 2 or arr.shape[1] != 3:
                raise MomaError(f"ObservedFrame.{name} must be (N, 3), got {arr.shape}")
        for name in ("target_xyz", "camera_xyz"):
            if getattr(self, name).shape != (3,):
                raise MomaError(f"ObservedFrame.{name} must be (3,), got {getattr(self, name)}")
        if len(self.floor_xyz) == 0 or len(self.target_points) == 0:
            raise MomaError("ObservedFrame needs floor points and target points")


def observe(frame: FrameArrays, metric_depth: bool = True) -> ObservedFrame:
    """The frame's floor, points off the floor and target, read as
    :func:`~momakitchen.perception.live.frame_inputs` reads them for a model (its
    default cloud settings); MomaError names a frame with no floor or no target."""
    from momakitchen.perception.live import frame_inputs

    clouds = frame_inputs(
        frame.depth,
        frame.valid,
        frame.rgb,
        frame.target_mask,
        list(frame.obstacle_masks),
        frame.intrinsics,
        frame.camera_to_base,
        metric_depth=metric_depth,
    )
    xyz = clouds.global_xyz.astype(np.float64)
    camera = (clouds.correction.matrix @ frame.camera_to_base)[:3, 3]
    return ObservedFrame(
        floor_xyz=clouds.floor_xyz.astype(np.float64),
        points=supported(xyz[xyz[:, 2] > OBSTACLE_MIN_Z]),
        target_points=xyz[clouds.global_align > 0],
        target_xyz=np.asarray(clouds.target_xyz, np.float64),
        camera_xyz=np.asarray(camera, np.float64),
        correction=clouds.correction,
    )


def supported(points: np.ndarray) -> np.ndarray:
    """The points with at least :data:`OBSTACLE_NEIGHBOURS` others within
    :data:`OBSTACLE_RADIUS`. Shapes: (M, 3) -> (K, 3), K <= M, in input order."""
    if len(points) == 0:
        return points
    counts = cKDTree(points).query_ball_point(points, OBSTACLE_RADIUS, return_length=True)
    return points[counts > OBSTACLE_NEIGHBOURS]


def free_floor(frame: ObservedFrame, footprint: tuple[float, float], ceiling: float) -> np.ndarray:
    """Floor points where the base's box (``footprint`` = length along its x, width,
    grown by :data:`FOOTPRINT_MARGIN`), centred there and turned to face the target as
    the poses are, holds no point of the frame between :data:`OBSTACLE_MIN_Z` and
    ``ceiling`` (m; the arm mount: the base and its pillar stand up to there).

    Shapes: -> (N,) bool over ``frame.floor_xyz``.
    """
    return footprint_free(frame.floor_xyz, frame.points, frame.target_xyz, footprint, ceiling)


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


def camera_side(frame: ObservedFrame) -> np.ndarray:
    """Floor points on the camera's side of the target: in the half-plane through the
    target that faces the camera (horizontally). Shapes: -> (N,) bool."""
    towards = frame.camera_xyz[:2] - frame.target_xyz[:2]
    return (frame.floor_xyz[:, :2] - frame.target_xyz[:2]) @ towards > 0


def target_normal(frame: ObservedFrame) -> np.ndarray | None:
    """The normal (3,) of the target's surface, towards the camera, where its points
    form a plane (a door, a drawer front, a board): thinner than
    :data:`PLANE_THICKNESS` and spread over :data:`PLANE_SPREAD` both ways; else None."""
    pts = frame.target_points
    if len(pts) < 10:
        return None
    centred = pts - pts.mean(axis=0)
    _, s, vh = np.linalg.svd(centred, full_matrices=False)
    std = s / math.sqrt(len(pts))
    if std[2] > PLANE_THICKNESS or std[1] < PLANE_SPREAD:
        return None
    n = vh[2]
    return -n if (frame.camera_xyz - pts.mean(axis=0)) @ n < 0 else n


def grasp_approaches(frame: ObservedFrame) -> list[np.ndarray | None]:
    """The approach directions (each (3,), towards the target) a grasp of the target may
    take, from the frame alone: against the surface's normal where the target is a plane
    (levelled for a front, straight down for a top); else horizontal from the base
    (None, as :meth:`~momakitchen.sim.reachability.ReachabilityMap.floor_map`
    reads it) or from above."""
    down = np.array([0.0, 0.0, -1.0])
    n = target_normal(frame)
    if n is None:
        return [None, down]
    if n[2] >= math.cos(math.radians(TOP_ANGLE)):
        return [down]
    if abs(n[2]) <= math.sin(math.radians(TOP_ANGLE)):
        h = -n[:2] / np.hypot(n[0], n[1])
        return [np.array([h[0], h[1], 0.0])]
    return [-n]
