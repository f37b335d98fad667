"""The classical base placement methods behind one entry point, :func:`place`.

Each method turns what a model reads (one RGB-D frame, the target's and obstacles'
masks, the camera's pose, the robot) into what a model answers: a map over the visible
floor and the Top-k base poses facing the target, as a
:class:`~momakitchen.models.inference.Prediction`. No label and no training: the bar a
learned map must clear (docs/PLACEMENT.md).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np

from momakitchen.errors import MomaError
from momakitchen.placement.body import PlacementRobot, placement_robot
from momakitchen.placement.observed import (
    ObservedFrame,
    camera_side,
    free_floor,
    grasp_approaches,
    observe,
)
from momakitchen.placement.ring import ring_map

if TYPE_CHECKING:
    from momakitchen.models.inference import Prediction

NEEDS_URDF = (
    "method 'reachability' needs a registered robot (its URDF), not one given by its "
    "numbers: register it from a URDF and YAML, or use method 'ring'"
)
# A method: the frame and the robot -> its map (N,) in [0, 1] over the frame's floor
# points, and what the robot should know (warnings).
PlacementMethod = Callable[[ObservedFrame, PlacementRobot], tuple[np.ndarray, list[str]]]


def reachability_map(frame: ObservedFrame, robot: PlacementRobot) -> tuple[np.ndarray, list[str]]:
    """The robot's inverse-reachability map at the target's grasp pose (its height, the
    approaches the frame suggests, :func:`~momakitchen.placement.observed.grasp_approaches`),
    the best approach at each floor point, on the floor the frame shows free within the
    base's footprint, on the camera's side of the target (a grasp from the far side
    would take a face of the target the frame does not show).

    Shapes: -> (N,) float64 in [0, 1] over ``frame.floor_xyz``.
    """
    from momakitchen.sim.reachability import ReachabilityMap

    if not robot.registered:
        raise MomaError(NEEDS_URDF)
    reach = ReachabilityMap.for_robot(robot.name, robot.mount_height)
    xy = frame.floor_xyz[:, :2]
    score = np.zeros(len(xy))
    for approach in grasp_approaches(frame):
        score = np.maximum(score, reach.floor_map(frame.target_xyz, approach, xy))
    usable = free_floor(frame, robot.footprint, robot.mount_height) & camera_side(frame)
    warnings = []
    if not (usable & (score > 0)).any():
        warnings.append(
            f"robot {robot.name!r} reaches the target from no visible floor that is free "
            "for its base on the camera's side"
        )
    return np.where(usable, score, 0.0), warnings


# The methods by name, in the order tables show them: the one source of truth.
METHODS: dict[str, PlacementMethod] = {"ring": ring_map, "reachability": reachability_map}
CLASSICAL_METHODS: tuple[str, ...] = tuple(METHODS)


def place(
    method: str,
    depth: np.ndarray | str | os.PathLike,
    intrinsics: Sequence[float] | Any,
    camera_to_base: np.ndarray | str | os.PathLike,
    target_mask: np.ndarray | str | os.PathLike,
    robot: str | Sequence[float] | Mapping[str, float] = "panda",
    *,
    rgb: np.ndarray | str | os.PathLike | None = None,
    obstacle_masks: Sequence[np.ndarray | str | os.PathLike] = (),
    top_k: int = 5,
    min_spread: float = 0.2,
    pick_radius: float = 0.0,
    metric_depth: bool = True,
    mount_height: float | None = None,
) -> Prediction:
    """Base poses from one RGB-D frame by a classical method (:data:`CLASSICAL_METHODS`).

    Takes the frame as :func:`momakitchen.predict` does, in the same forms, and answers
    in the same form: the method's map over the visible floor (``affordance``; zero
    ``uncertainty``) and the Top-k poses facing the target (``model`` is the method's
    name). The floor plane is fitted to the frame as for a model.

    Args:
        method: ``"ring"`` or ``"reachability"`` (docs/PLACEMENT.md).
        depth: (H, W) metres, or a ``.npy`` (metres) / 16-bit ``.png`` (millimetres) file;
            0 and NaN are invalid and ignored.
        intrinsics: ``(fx, fy, cx, cy)`` in pixels or an
            :class:`~momakitchen.perception.camera.Intrinsics`.
        camera_to_base: (4, 4) rigid transform from the camera (x right, y down, z forward)
            to the robot base frame (x forward, y left, z up, z = 0 on the floor).
        target_mask: (H, W) mask of the target; non-zero = target.
        robot: a registered robot name or a descriptor
            (:func:`~momakitchen.perception.inputs.robot_input`); ``reachability`` needs a
            name (a URDF).
        rgb: optional (H, W, 3) image, checked but not used.
        obstacle_masks: optional (H, W) masks of obstacles; their points are obstacles
            as every point above the floor is.
        top_k, min_spread: number of poses (1-50) and their minimum spacing (m).
        pick_radius: rank the poses by the map averaged over this radius (m, 0-1; 0: the
            raw map), as for :func:`momakitchen.predict`.
        metric_depth: False for depth known only up to scale (monocular).
        mount_height: the arm mount's height (m) of a robot given by name, where it
            differs from the robot's own (a configuration's drawn mount).

    Shapes: ``Prediction.floor_xyz`` (N, 3), ``affordance`` (N,) in [0, 1], ``poses``
    (k, 3) rows ``x, y, yaw``, best first: up to ``top_k``, only where the map is
    positive (none, with a warning, where the frame shows no floor the method accepts).
    """
    from momakitchen.models.inference import map_prediction
    from momakitchen.perception.inputs import load_frame

    if method not in METHODS:
        raise MomaError(
            f"unknown placement method {method!r}; known: {', '.join(CLASSICAL_METHODS)}"
        )
    if not (isinstance(top_k, int) and 1 <= top_k <= 50):
        raise MomaError(f"top_k must be in [1, 50], got {top_k}")
    if not 0.0 <= min_spread <= 5.0:
        raise MomaError(f"min_spread must be in [0, 5] m, got {min_spread}")
    if not 0.0 <= pick_radius <= 1.0:
        raise MomaError(f"pick_radius must be in [0, 1] m, got {pick_radius}")
    body = placement_robot(robot, mount_height)
    if method == "reachability" and not body.registered:  # before reading the frame
        raise MomaError(NEEDS_URDF)
    frame = load_frame(depth, intrinsics, camera_to_base, target_mask, obstacle_masks, rgb)
    seen = observe(frame, metric_depth)
    affordance, warnings = METHODS[method](seen, body)
    pred = map_prediction(
        seen.floor_xyz,
        affordance,
        np.zeros(len(affordance)),
        seen.target_xyz,
        body.name,
        method,
        top_k=top_k,
        min_spread=min_spread,
        pick_radius=pick_radius,
        correction=seen.correction,
        warnings=tuple(warnings),
    )
    # A pose where the map is 0 (no free floor, out of reach) is no candidate: such poses
    # come last in the ranking, so dropping them leaves the best of the others.
    keep = pred.pose_scores > 0
    return replace(
        pred,
        poses=pred.poses[keep],
        pose_scores=pred.pose_scores[keep],
        pose_uncertainty=pred.pose_uncertainty[keep],
    )


def place_frame(
    method: str,
    frame: Any,
    robot: str | Sequence[float] | Mapping[str, float],
    *,
    mount_height: float | None = None,
    metric_depth: bool = True,
    top_k: int = 1,
    pick_radius: float = 0.0,
) -> Prediction:
    """:func:`place` on a :class:`~momakitchen.perception.sensors.Frame` (its depth,
    intrinsics, camera pose, target and obstacle masks), as the tracks give one."""
    return place(
        method,
        frame.depth,
        frame.intrinsics,
        frame.camera_to_base,
        frame.target_mask,
        robot,
        obstacle_masks=list(frame.obstacle_masks),
        top_k=top_k,
        pick_radius=pick_radius,
        metric_depth=metric_depth,
        mount_height=mount_height,
    )


def map_at(prediction: Prediction, floor_xy: np.ndarray, match: float = 0.05) -> np.ndarray:
    """A method's map read at other floor points of the same frame (a track's own floor
    points): the value of the nearest of its points within ``match`` m, else 0.

    Shapes: ``floor_xy`` (M, 2) base-frame xy; returns (M,).
    """
    from scipy.spatial import cKDTree

    floor_xy = np.asarray(floor_xy, np.float64).reshape(-1, 2)
    if not len(prediction.floor_xyz):
        return np.zeros(len(floor_xy))
    dist, idx = cKDTree(np.asarray(prediction.floor_xyz)[:, :2]).query(floor_xy)
    return np.where(dist <= match, np.asarray(prediction.affordance)[idx], 0.0)
