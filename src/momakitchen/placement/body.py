"""The robot as the classical placement methods need it: its numbers and its base."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from momakitchen.errors import MomaError
from momakitchen.robots.spec import DEFAULT_FOOTPRINT

# A robot given by its numbers stands on the built-in robots' base (its footprint,
# robots.spec.DEFAULT_FOOTPRINT) with its arm this far ahead of the base's centre, where
# every built-in arm stands.
DEFAULT_MOUNT_OFFSET = 0.15


@dataclass(frozen=True)
class PlacementRobot:
    """A robot's numbers (metres) for base placement.

    Attributes:
        name: the registered name, or ``"custom"`` for a robot given by its numbers (it
            has no URDF, so no reachability map).
        reach: the arm's reach.
        mount_height: the arm mount's height above the floor.
        shoulder_height: the shoulder's height above the floor.
        mount_offset_x: the arm mount's position ahead of the base's centre.
        footprint: the base's length (along its x) and width.
    """

    name: str
    reach: float
    mount_height: float
    shoulder_height: float
    mount_offset_x: float
    footprint: tuple[float, float]

    def __post_init__(self) -> None:
        for key, lo, hi in (
            ("reach", 0.1, 3.0),
            ("mount_height", 0.0, 3.0),
            ("shoulder_height", 0.0, 4.0),
            ("mount_offset_x", -1.0, 1.0),
        ):
            value = getattr(self, key)
            if not (math.isfinite(value) and lo <= value <= hi):
                raise MomaError(f"PlacementRobot.{key} must be in [{lo:g}, {hi:g}] m, got {value}")
        if len(self.footprint) != 2 or not all(0.1 <= f <= 2.0 for f in self.footprint):
            raise MomaError(f"PlacementRobot.footprint must be in [0.1, 2] m, got {self.footprint}")

    @property
    def registered(self) -> bool:
        """Whether the robot is known by name (it has a URDF)."""
        return self.name != "custom"


def placement_robot(
    robot: str | Sequence[float] | Mapping[str, float], mount_height: float | None = None
) -> PlacementRobot:
    """A robot as :func:`momakitchen.predict` takes it (a registered name or a
    descriptor, :func:`~momakitchen.perception.inputs.robot_input`) with its base; for a
    name, the arm at ``mount_height`` (default its own; any height of the allowed range).
    A descriptor already holds its mount height: giving one too is an error."""
    from momakitchen.perception.inputs import robot_input
    from momakitchen.robots.descriptor import robot_descriptor
    from momakitchen.robots.spec import get_robot_spec
    from momakitchen.robots.urdf import mounted

    if isinstance(robot, str):
        spec = mounted(get_robot_spec(robot), mount_height)
        d = robot_descriptor(spec)
        return PlacementRobot(
            robot,
            float(spec.reach),
            float(spec.mount_height),
            float(d[5]),
            float(spec.mount_offset_x),
            (float(spec.footprint[0]), float(spec.footprint[1])),
        )
    if mount_height is not None:
        raise MomaError(
            "mount_height goes with a robot name; a robot given by its numbers carries "
            "its own mount height"
        )
    _, vec = robot_input(robot)
    return PlacementRobot(
        "custom",
        float(vec[0]),
        float(vec[1]),
        float(vec[5]),
        DEFAULT_MOUNT_OFFSET,
        DEFAULT_FOOTPRINT,
    )
