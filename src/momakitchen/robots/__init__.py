"""Mobile manipulators: specifications with their models (one registry), and the Robot API.

``ROBOTS`` (``spec.py``) is the single source of truth: each ``RobotSpec`` holds the
numbers (name, reach, mount height, DoF, end-effector) and the model (``spec.model``,
``arms.py``: the robot's URDF of arm and tool). Every robot, built-in or a user's, comes
from a URDF and a YAML file through one loader (``user.py``; the built-ins' files are in
``shipped/``), and ``register_robot`` is the one way in. ``urdf.py`` writes one URDF per
robot (mobile base + arm + tool); ``robot.py`` drives it in PyBullet (placement, joints,
FK), with IK in ``ik.py``, reach in ``reach.py``, collisions in ``collisions.py`` and the
gripper or suction cup in ``tools.py`` (``robot.tool``).
"""

# The loader: it registers the built-ins on the registry's first read (user.py).
import momakitchen.robots.user  # noqa: F401
from momakitchen.robots.descriptor import robot_descriptor
from momakitchen.robots.spec import (
    DESCRIPTOR_DIM,
    DESCRIPTOR_NAMES,
    DESCRIPTOR_VERSION,
    ROBOTS,
    RobotSpec,
    get_robot_spec,
    register_robot,
)

__all__ = [
    "DESCRIPTOR_DIM",
    "DESCRIPTOR_NAMES",
    "DESCRIPTOR_VERSION",
    "ROBOTS",
    "Contact",
    "IKResult",
    "Robot",
    "RobotSpec",
    "get_robot_spec",
    "register_robot",
    "register_user_robot",
    "robot_descriptor",
    "robot_urdf_path",
]


def __getattr__(name: str):
    # Lazy: importing the registry must not import PyBullet (sampling code stays light).
    if name in ("Robot", "IKResult", "Contact"):
        from momakitchen.robots import robot

        return getattr(robot, name)
    if name == "register_user_robot":
        from momakitchen.robots.user import register_user_robot

        return register_user_robot
    if name == "robot_urdf_path":
        from momakitchen.robots.urdf import robot_urdf_path

        return robot_urdf_path
    raise AttributeError(f"module 'momakitchen.robots' has no attribute {name!r}")
