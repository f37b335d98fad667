"""How a robot is built: its arm and tool from one URDF file, as typed data.

Every robot, built-in or a user's, is a URDF of its arm and tool plus a YAML of its numbers
(``user.py`` loads both; the built-ins' files are in ``shipped/``). The built-in arms'
kinematic figures are the manufacturers' (``docs/ROBOTS.md``); the collision geometry of
the arms made from joint tables (a capsule along each link, a cylinder around each joint)
and the grippers' palm and finger sizes are modelling choices close to the real ones.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import pybullet_data

from momakitchen.errors import MomaError

PI = math.pi
PYBULLET_DATA = Path(pybullet_data.getDataPath())


@dataclass(frozen=True)
class UrdfArm:
    """The arm of a robot's URDF, re-emitted under the mobile base.

    Attributes:
        urdf: path of the URDF (the arm with its tool).
        root_link: the arm's base link (attached to the mount).
        flange_link: link whose frame is the tool flange; the links below it are the tool.
        mount_yaw: rotation of ``root_link`` about the vertical on the mobile base, radians.
        link_scale: every length of the arm (joint origins, collision and visual geometry,
            centres of mass; not the tool below ``flange_link``) is multiplied by this
            (``scaled.py``); 1.0: the file as it is.
    """

    urdf: Path
    root_link: str
    flange_link: str
    mount_yaw: float = 0.0
    link_scale: float = 1.0


@dataclass(frozen=True)
class UrdfTool:
    """The end-effector of a robot, part of its URDF.

    Attributes:
        kind: ``"parallel_gripper"`` or ``"suction"``.
        tcp_link: the URDF link whose frame is the tool centre point (z = approach).
        finger_joints: prismatic finger joints (grippers), driven one by one.
        finger_force: closing force per finger in N.
        contact_distance: suction attaches within this distance of a surface, metres.
        face_tolerance: suction: a contact counts as on the cup's face when it lies at most
            this far behind the TCP's xy plane, metres (not along the side of the stem).
    """

    kind: str
    tcp_link: str
    finger_joints: tuple[str, ...] = ()
    finger_force: float = 40.0
    contact_distance: float = 0.004
    face_tolerance: float = 0.008

    def __post_init__(self) -> None:
        if self.kind not in ("parallel_gripper", "suction"):
            raise MomaError(
                f"end_effector must be 'parallel_gripper' or 'suction', got {self.kind!r}"
            )
        if not self.tcp_link:
            raise MomaError("end_effector_link must be a non-empty link name")


@dataclass(frozen=True)
class RobotModel:
    """How to build one robot's URDF: the arm and the end-effector on the mobile base.

    A model is registered only as part of its robot's ``RobotSpec`` (``RobotSpec.model``),
    so the numbers and the build cannot drift apart.

    Attributes:
        arm: the arm, from a URDF file.
        end_effector: the tool on the flange, from the same file.
        home: a comfortable joint configuration (IK rest pose), len == DoF.
        source: where the figures come from (shown in docs).
    """

    arm: UrdfArm
    end_effector: UrdfTool
    home: tuple[float, ...] = ()
    source: str = ""

    @property
    def tool_kind(self) -> str:
        """``"parallel_gripper"`` or ``"suction"``: what the end-effector is."""
        return self.end_effector.kind
