"""``ring``: stand at a comfortable distance from the target, on floor the camera sees free.

The simplest rule a roboticist would try first. The arm works best well inside its
reach, so the base stands where the target lies :data:`COMFORT` of the arm's reach from
its shoulder (the target's height from the frame, the shoulder's from the robot):

    standoff = clip(mount_offset_x + sqrt(max(0, (COMFORT * reach)^2 - (z_target - z_shoulder)^2)),
                    footprint_length / 2 + CLEARANCE,  mount_offset_x + reach)

measured horizontally from the base's centre to the target. The map is a Gaussian band
of width :data:`BAND` about that distance, cut where the target lies beyond the reach
from the shoulder, on the floor the frame shows free of obstacle points within the
base's footprint, on the camera's side of the target. The constants
come from the geometry alone: no dataset was used to choose them.
"""

from __future__ import annotations

import math

import numpy as np

from momakitchen.placement.body import PlacementRobot
from momakitchen.placement.observed import ObservedFrame, camera_side, free_floor

# The target at 70 % of the reach from the shoulder: the wrist keeps room to turn to the
# approach direction (its centre stands the tool's length back from the TCP, 0.10-0.17 m
# on the registry's arms, about a fifth of their reach), and a stop error of a band's
# width (BAND) still leaves the target within reach.
COMFORT = 0.7
# The base's front edge stays this far (m) from the target's point.
CLEARANCE = 0.05
# Standard deviation (m) of the band: the driven track's stop errors are a few
# centimetres; a band this wide still ranks every floor point around the ring.
BAND = 0.1


def ring_standoff(robot: PlacementRobot, target_z: float) -> float:
    """The ring's radius (m): the horizontal distance from the base's centre to the
    target (module docstring)."""
    rise = target_z - robot.shoulder_height
    horizontal = math.sqrt(max(0.0, (COMFORT * robot.reach) ** 2 - rise**2))
    lo = robot.footprint[0] / 2 + CLEARANCE
    hi = max(lo, robot.mount_offset_x + robot.reach)
    return float(np.clip(robot.mount_offset_x + horizontal, lo, hi))


def shoulder_distance(robot: PlacementRobot, distance: np.ndarray, target_z: float) -> np.ndarray:
    """The target's distance from the shoulder (m) for bases ``distance`` (m, (N,))
    from it horizontally, facing it (the shoulder above the arm mount)."""
    return np.hypot(distance - robot.mount_offset_x, target_z - robot.shoulder_height)


def ring_map(frame: ObservedFrame, robot: PlacementRobot) -> tuple[np.ndarray, list[str]]:
    """The ring's map over the frame's floor points and what the robot should know.

    Shapes: -> (N,) float64 in [0, 1] over ``frame.floor_xyz``.
    """
    standoff = ring_standoff(robot, float(frame.target_xyz[2]))
    d = np.hypot(*(frame.floor_xyz[:, :2] - frame.target_xyz[:2]).T)
    band = np.exp(-0.5 * ((d - standoff) / BAND) ** 2)
    within = shoulder_distance(robot, d, float(frame.target_xyz[2])) <= robot.reach
    usable = within & free_floor(frame, robot.footprint, robot.mount_height) & camera_side(frame)
    warnings = []
    if not usable.any():
        warnings.append("no visible floor within reach is free for the base on the camera's side")
    return np.where(usable, band, 0.0), warnings
