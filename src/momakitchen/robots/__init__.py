"""Mobile manipulators: registry of robot specifications (one source of truth)."""

from momakitchen.robots.spec import ROBOTS, RobotSpec, get_robot_spec, register_robot

__all__ = ["ROBOTS", "RobotSpec", "get_robot_spec", "register_robot"]
