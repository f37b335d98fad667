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

from momakitchen.errors import MomaError
from momakitchen.perception.floor import FloorCorrection
from momakitchen.perception.footprint import base_obstacles, footprint_free
from momakitchen.perception.inputs import FrameArrays

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
        points=base_obstacles(xyz),
        target_points=xyz[clouds.global_align > 0],
        target_xyz=np.asarray(clouds.target_xyz, np.float64),
        camera_xyz=np.asarray(camera, np.float64),
        correction=clouds.correction,
    )


def free_floor(frame: ObservedFrame, footprint: tuple[float, float], ceiling: float) -> np.ndarray:
    """Floor points where the base's box (``footprint`` = length along its x, width,
    grown by a margin), centred there and turned to face the target as the poses are,
    holds no point of the frame up to ``ceiling`` (m; the arm mount: the base and its
    pillar stand up to there): :func:`~momakitchen.perception.footprint.footprint_free`.

    Shapes: -> (N,) bool over ``frame.floor_xyz``.
    """
    return footprint_free(frame.floor_xyz, frame.points, frame.target_xyz, footprint, ceiling)


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
