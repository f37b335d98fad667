"""Mobile manipulators: registry of robot specifications (one source of truth)."""

from momakitchen.robots.spec import (
    DESCRIPTOR_DIM,
    DESCRIPTOR_NAMES,
    DESCRIPTOR_VERSION,
    ROBOTS,
    RobotSpec,
    get_robot_spec,
    register_robot,
    robot_descriptor,
)

__all__ = [
    "DESCRIPTOR_DIM",
    "DESCRIPTOR_NAMES",
    "DESCRIPTOR_VERSION",
    "ROBOTS",
    "RobotSpec",
    "get_robot_spec",
    "register_robot",
    "robot_descriptor",
]
