"""Arm and end-effector definitions: the published kinematic figures as typed data.

Every number in the joint tables below is the manufacturer's (``docs/ROBOTS.md``):
joint origins (parent frame -> child frame, URDF convention: ``rpy`` is fixed-axis roll,
pitch, yaw), joint axes and position limits. The arms of ``panda`` and ``xarm6`` come from
the URDFs shipped in ``pybullet_data`` (meshes included); the other four are built from
these tables with simple collision geometry (a capsule along each link, a cylinder around
each joint).

End-effector dimensions (palm and finger sizes, TCP offsets) of the grippers that are not
shipped as URDF are modelling choices close to the real grippers; they are not kinematic
figures of the arms.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import pybullet_data

from momakitchen.errors import MomaError

PI = math.pi
PYBULLET_DATA = Path(pybullet_data.getDataPath())


def _vec3(value: tuple[float, ...], what: str) -> tuple[float, float, float]:
    if len(value) != 3 or not all(math.isfinite(float(v)) for v in value):
        raise MomaError(f"{what} must be 3 finite numbers, got {value!r}")
    return (float(value[0]), float(value[1]), float(value[2]))


@dataclass(frozen=True)
class JointDef:
    """One revolute joint of an arm built from a joint table.

    Attributes:
        name: joint name in the generated URDF.
        xyz: origin translation (parent link frame -> child link frame), metres.
        rpy: origin rotation, fixed-axis roll, pitch, yaw in radians.
        axis: rotation axis in the child frame (unit vector).
        lower, upper: position limits in radians.
        effort: motor force limit in N·m.
        velocity: velocity limit in rad/s.
        radius: collision radius of the child link (capsule and joint housing), metres.
    """

    name: str
    xyz: tuple[float, float, float]
    rpy: tuple[float, float, float]
    axis: tuple[float, float, float]
    lower: float
    upper: float
    effort: float = 50.0
    velocity: float = 2.0
    radius: float = 0.045

    def __post_init__(self) -> None:
        object.__setattr__(self, "xyz", _vec3(self.xyz, f"joint {self.name!r} xyz"))
        object.__setattr__(self, "rpy", _vec3(self.rpy, f"joint {self.name!r} rpy"))
        object.__setattr__(self, "axis", _vec3(self.axis, f"joint {self.name!r} axis"))
        if abs(math.hypot(*self.axis) - 1.0) > 1e-6:
            raise MomaError(f"joint {self.name!r}: axis must be a unit vector, got {self.axis}")
        if not self.lower < self.upper:
            raise MomaError(
                f"joint {self.name!r}: lower limit {self.lower} must be below upper {self.upper}"
            )
        if self.effort <= 0 or self.velocity <= 0 or not 0.005 <= self.radius <= 0.2:
            raise MomaError(
                f"joint {self.name!r}: effort, velocity must be > 0 and radius in [0.005, 0.2], "
                f"got {self.effort}, {self.velocity}, {self.radius}"
            )


@dataclass(frozen=True)
class BuiltArm:
    """An arm generated from a joint table.

    Attributes:
        joints: the revolute joints from the arm base outwards.
        flange_xyz, flange_rpy: fixed transform from the last link to the tool flange.
        base_radius, base_height: the arm's base housing (a cylinder below joint 1).
        link_masses: mass of each moving link (len == len(joints)), kg.
        mount_yaw: rotation of the arm base about the vertical on the mobile base, chosen
            so that joint 1 at 0 points the arm forward (+x of the mobile base).
    """

    joints: tuple[JointDef, ...]
    flange_xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    flange_rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    base_radius: float = 0.06
    base_height: float = 0.1
    link_masses: tuple[float, ...] = ()
    mount_yaw: float = 0.0

    def __post_init__(self) -> None:
        if not 3 <= len(self.joints) <= 10:
            raise MomaError(f"an arm needs 3 to 10 joints, got {len(self.joints)}")
        if self.link_masses and len(self.link_masses) != len(self.joints):
            raise MomaError(
                f"link_masses needs one mass per joint ({len(self.joints)}), "
                f"got {len(self.link_masses)}"
            )
        object.__setattr__(self, "flange_xyz", _vec3(self.flange_xyz, "flange xyz"))
        object.__setattr__(self, "flange_rpy", _vec3(self.flange_rpy, "flange rpy"))


@dataclass(frozen=True)
class ShippedArm:
    """An arm taken from a URDF file (with meshes) and re-emitted under the mobile base.

    Attributes:
        urdf: path of the source URDF.
        root_link: the arm's base link (attached to the mount).
        flange_link: link whose frame is the tool flange.
        keep_links: links kept from the file (arm links and end-effector links wanted);
            ``None`` keeps every link.
        limits: joint name -> (lower, upper) replacing the file's limits (published limits).
        drop_mimic: remove ``<mimic>`` tags (PyBullet ignores them; fingers are driven).
        mount_yaw: rotation of ``root_link`` about the vertical on the mobile base, radians.
    """

    urdf: Path
    root_link: str
    flange_link: str
    keep_links: tuple[str, ...] | None = None
    limits: tuple[tuple[str, float, float], ...] = ()
    drop_mimic: bool = True
    mount_yaw: float = 0.0


@dataclass(frozen=True)
class ParallelGripper:
    """A two-finger parallel gripper with prismatic fingers (physically simulated).

    Frame convention (shared by all robots): the TCP frame's z axis points out of the
    flange (approach direction) and the fingers close along its y axis.

    Attributes:
        tcp_offset: flange -> TCP distance along z (grasp centre between the finger pads).
        max_opening: distance between the finger pads when fully open, metres.
        palm_size: (x, y, z) size of the palm box (mounted on the flange).
        finger_size: (x thickness across the closing direction, y pad thickness, z length).
        existing_fingers: names of prismatic finger joints already present in a shipped
            URDF (then nothing is generated but the TCP link).
        palm_mesh: optional mesh used for the palm's visual and collision geometry.
        yaw: rotation of the gripper about the flange z axis, radians.
        finger_force: closing force per finger in N.
    """

    tcp_offset: float
    max_opening: float = 0.08
    palm_size: tuple[float, float, float] = (0.06, 0.13, 0.08)
    finger_size: tuple[float, float, float] = (0.022, 0.012, 0.055)
    existing_fingers: tuple[str, ...] = ()
    palm_mesh: Path | None = None
    yaw: float = 0.0
    finger_force: float = 40.0

    def __post_init__(self) -> None:
        if not 0.02 <= self.tcp_offset <= 0.4:
            raise MomaError(f"gripper tcp_offset must be in [0.02, 0.4] m, got {self.tcp_offset}")
        if not 0.01 <= self.max_opening <= 0.3:
            raise MomaError(f"gripper max_opening must be in [0.01, 0.3] m, got {self.max_opening}")
        if self.finger_force <= 0:
            raise MomaError(f"gripper finger_force must be > 0, got {self.finger_force}")


@dataclass(frozen=True)
class SuctionCup:
    """A suction tool: a rigid stem with a cup whose face is the TCP.

    Attributes:
        tcp_offset: flange -> cup face distance along z, metres.
        cup_radius: radius of the cup face, metres.
        stem_radius: radius of the stem, metres.
        contact_distance: the cup attaches only if its face is within this distance of
            a surface (contact, not a gap), metres.
    """

    tcp_offset: float
    cup_radius: float = 0.02
    stem_radius: float = 0.015
    contact_distance: float = 0.004

    def __post_init__(self) -> None:
        if not 0.02 <= self.tcp_offset <= 0.4:
            raise MomaError(f"suction tcp_offset must be in [0.02, 0.4] m, got {self.tcp_offset}")
        if not 0.0 < self.contact_distance <= 0.01:
            raise MomaError(
                f"suction contact_distance must be in (0, 0.01] m, got {self.contact_distance}"
            )


@dataclass(frozen=True)
class UserTool:
    """The end-effector of a user robot, already part of the user's URDF.

    Attributes:
        kind: ``"parallel_gripper"`` or ``"suction"``.
        tcp_link: the URDF link whose frame is the tool centre point (z = approach).
        finger_joints: prismatic finger joints (grippers), driven one by one.
        finger_force: closing force per finger in N.
        contact_distance: suction attaches within this distance of a surface, metres.
    """

    kind: str
    tcp_link: str
    finger_joints: tuple[str, ...] = ()
    finger_force: float = 40.0
    contact_distance: float = 0.004

    def __post_init__(self) -> None:
        if self.kind not in ("parallel_gripper", "suction"):
            raise MomaError(
                f"end_effector must be 'parallel_gripper' or 'suction', got {self.kind!r}"
            )
        if not self.tcp_link:
            raise MomaError("end_effector_link must be a non-empty link name")


EndEffector = ParallelGripper | SuctionCup | UserTool


@dataclass(frozen=True)
class RobotModel:
    """How to build one robot's URDF: the arm and the end-effector on the mobile base.

    A model is registered only as part of its robot's ``RobotSpec`` (``RobotSpec.model``),
    so the numbers and the build cannot drift apart.

    Attributes:
        arm: a built arm (joint table) or a shipped one (URDF file).
        end_effector: the tool on the flange.
        home: a comfortable joint configuration (IK rest pose), len == DoF.
        source: where the figures come from (shown in docs).
    """

    arm: BuiltArm | ShippedArm
    end_effector: EndEffector
    home: tuple[float, ...] = ()
    source: str = ""

    @property
    def tool_kind(self) -> str:
        """``"parallel_gripper"`` or ``"suction"``: what the end-effector is."""
        if isinstance(self.end_effector, UserTool):
            return self.end_effector.kind
        return "suction" if isinstance(self.end_effector, SuctionCup) else "parallel_gripper"


# --------------------------------------------------------------------------------------
# Joint tables (docs/ROBOTS.md). Radii cover the real links (modelling choice).

_Z = (0.0, 0.0, 1.0)
_Y = (0.0, 1.0, 0.0)
_NZ = (0.0, 0.0, -1.0)
_NX = (-1.0, 0.0, 0.0)
_TWO_PI = 2 * PI

UR5E_ARM = BuiltArm(
    joints=(
        JointDef(
            "shoulder_pan_joint", (0, 0, 0.1625), (0, 0, 0), _Z, -_TWO_PI, _TWO_PI, 150, PI, 0.065
        ),
        JointDef(
            "shoulder_lift_joint", (0, 0, 0), (PI / 2, 0, 0), _Z, -_TWO_PI, _TWO_PI, 150, PI, 0.06
        ),
        JointDef("elbow_joint", (-0.425, 0, 0), (0, 0, 0), _Z, -PI, PI, 150, PI, 0.05),
        JointDef(
            "wrist_1_joint", (-0.3922, 0, 0.1333), (0, 0, 0), _Z, -_TWO_PI, _TWO_PI, 28, PI, 0.045
        ),
        JointDef(
            "wrist_2_joint", (0, -0.0997, 0), (PI / 2, 0, 0), _Z, -_TWO_PI, _TWO_PI, 28, PI, 0.045
        ),
        JointDef(
            "wrist_3_joint", (0, 0.0996, 0), (PI / 2, PI, PI), _Z, -_TWO_PI, _TWO_PI, 28, PI, 0.04
        ),
    ),
    base_radius=0.075,
    base_height=0.09,
    link_masses=(3.7, 8.4, 2.3, 1.2, 1.2, 0.25),
    # UR's base frame has the arm stretching along -x at joint 1 = 0.
    mount_yaw=PI,
)

# Flexiv Rizon 4: BestMan's soft limits (the controller's), hard limits in docs/ROBOTS.md.
FLEXIV_ARM = BuiltArm(
    joints=(
        JointDef("joint1", (0, 0, 0.155), (0, 0, -PI), _Z, -2.7925, 2.7925, 123, 2.0944, 0.06),
        JointDef("joint2", (0, 0.03, 0.21), (0, 0, 0), _Y, -2.2689, 2.2689, 123, 2.0944, 0.06),
        JointDef("joint3", (0, 0.035, 0.205), (0, 0, 0), _Z, -2.9671, 2.9671, 64, 2.4435, 0.05),
        JointDef(
            "joint4", (-0.02, -0.03, 0.19), (0, 0, -PI), _Y, -1.8675, 2.6878, 64, 2.4435, 0.05
        ),
        JointDef(
            "joint5", (-0.02, 0.025, 0.195), (0, 0, -PI), _Z, -2.9671, 2.9671, 39, 4.8869, 0.045
        ),
        JointDef("joint6", (0, 0.03, 0.19), (0, 0, 0), _Y, -1.3963, 4.5379, 39, 4.8869, 0.045),
        JointDef(
            "joint7", (-0.015, 0.073, 0.11), (0, -PI / 2, 0), _Z, -2.9671, 2.9671, 39, 4.8869, 0.04
        ),
    ),
    flange_xyz=(0, 0, 0.081),
    flange_rpy=(0, 0, -PI),
    base_radius=0.07,
    base_height=0.1,
    link_masses=(3.7, 2.7, 2.4, 2.4, 1.7, 1.6, 0.6),
)

REALMAN_ARM = BuiltArm(
    joints=(
        JointDef("joint1", (0, 0, 0.172), (0, 0, 0), _Z, -3.107, 3.107, 60, 3.14, 0.06),
        JointDef(
            "joint2", (-0.086, 0, 0), (-1.5708, -1.5708, 0), _Z, -3.107, 3.107, 60, 3.14, 0.06
        ),
        JointDef(
            "joint3", (0.38, 0, -0.00010023), (0, 0, 1.5708), _Z, -3.107, 2.531, 30, 3.14, 0.05
        ),
        JointDef(
            "joint4",
            (0.069, -0.405, 0.000099684),
            (1.5708, 0, 0),
            _Z,
            -3.107,
            3.107,
            10,
            3.14,
            0.045,
        ),
        JointDef("joint5", (0, 0, 0), (1.5708, 0, 3.1416), _Z, -3.107, 3.107, 10, 3.14, 0.045),
        JointDef("joint6", (0, 0.1435, 0), (1.5708, 0, -3.1416), _Z, -6.283, 6.283, 10, 3.14, 0.04),
    ),
    base_radius=0.07,
    base_height=0.1,
    link_masses=(2.0, 3.0, 1.5, 1.2, 0.8, 0.3),
)

ELEPHANT_ARM = BuiltArm(
    joints=(
        JointDef("joint1", (0, 0, 0.22934), (0, 0, 0), _Z, -3.14, 3.14159, 60, 3.14, 0.055),
        JointDef("joint2", (0, 0, 0), (1.5707, -1.5708, 0), _NZ, -4.71, 1.5707, 60, 3.14, 0.055),
        JointDef("joint3", (0.27, 0, 0), (0, 0, 0), _NZ, -2.61, 2.618, 30, 3.14, 0.045),
        JointDef("joint4", (0.267, 0, -0.0745), (0, 0, 1.5708), _NZ, -4.53, 1.3962, 10, 3.14, 0.04),
        JointDef(
            "joint5", (0, -0.095, 0.002), (1.5707, -1.5707, 0), _Z, -2.93, 2.9321, 10, 3.14, 0.04
        ),
        JointDef("joint6", (-0.054, 0, 0), (-1.5707, 0, 0), _NX, -3.03, 3.0368, 10, 3.14, 0.035),
    ),
    base_radius=0.065,
    base_height=0.1,
    link_masses=(2.0, 2.5, 1.5, 0.8, 0.6, 0.3),
    # Joint 1 at 0 stretches the arm along -x; its limits are +-pi, so turn the base
    # rather than work at the wrap-around.
    mount_yaw=PI,
)

# Universal Robots UR10e: UR's published DH table (d1 0.1807, a2 -0.6127, a3 -0.57155,
# d4 0.17415, d5 0.11985, d6 0.11655) written as the ROS description's chain, like the UR5e;
# limits, efforts and speeds from the UR10e user manual (elbow +-pi as in ROS).
UR10E_ARM = BuiltArm(
    joints=(
        JointDef(
            "shoulder_pan_joint",
            (0, 0, 0.1807),
            (0, 0, 0),
            _Z,
            -_TWO_PI,
            _TWO_PI,
            330,
            2.0944,
            0.075,
        ),
        JointDef(
            "shoulder_lift_joint",
            (0, 0, 0),
            (PI / 2, 0, 0),
            _Z,
            -_TWO_PI,
            _TWO_PI,
            330,
            2.0944,
            0.075,
        ),
        JointDef("elbow_joint", (-0.6127, 0, 0), (0, 0, 0), _Z, -PI, PI, 150, PI, 0.06),
        JointDef(
            "wrist_1_joint",
            (-0.57155, 0, 0.17415),
            (0, 0, 0),
            _Z,
            -_TWO_PI,
            _TWO_PI,
            56,
            PI,
            0.05,
        ),
        JointDef(
            "wrist_2_joint", (0, -0.11985, 0), (PI / 2, 0, 0), _Z, -_TWO_PI, _TWO_PI, 56, PI, 0.05
        ),
        JointDef(
            "wrist_3_joint",
            (0, 0.11655, 0),
            (PI / 2, PI, PI),
            _Z,
            -_TWO_PI,
            _TWO_PI,
            56,
            PI,
            0.045,
        ),
    ),
    base_radius=0.09,
    base_height=0.1,
    link_masses=(7.369, 13.051, 3.989, 2.1, 1.98, 0.615),
    # As the UR5e: at joint 1 = 0 the published chain stretches along -x.
    mount_yaw=PI,
)

# Kinova Gen3 7-DoF: the joint origins of Kinova's ROS description (kortex_description,
# gen3 7dof), which realise the user guide's DH table; joints 1, 3, 5 and 7 turn without
# limit (+-2 pi here), 2, 4 and 6 within the user guide's ranges (128.9, 147.8, 120.3 deg).
GEN3_ARM = BuiltArm(
    joints=(
        JointDef("joint_1", (0, 0, 0.15643), (PI, 0, 0), _Z, -_TWO_PI, _TWO_PI, 39, 1.3963, 0.05),
        JointDef(
            "joint_2",
            (0, 0.005375, -0.12838),
            (PI / 2, 0, 0),
            _Z,
            -2.2497,
            2.2497,
            39,
            1.3963,
            0.05,
        ),
        JointDef(
            "joint_3",
            (0, -0.21038, -0.006375),
            (-PI / 2, 0, 0),
            _Z,
            -_TWO_PI,
            _TWO_PI,
            39,
            1.3963,
            0.045,
        ),
        JointDef(
            "joint_4",
            (0, 0.006375, -0.21038),
            (PI / 2, 0, 0),
            _Z,
            -2.5796,
            2.5796,
            39,
            1.3963,
            0.045,
        ),
        JointDef(
            "joint_5",
            (0, -0.20843, -0.006375),
            (-PI / 2, 0, 0),
            _Z,
            -_TWO_PI,
            _TWO_PI,
            9,
            1.2218,
            0.04,
        ),
        JointDef(
            "joint_6",
            (0, 0.00017505, -0.10593),
            (PI / 2, 0, 0),
            _Z,
            -2.0997,
            2.0997,
            9,
            1.2218,
            0.04,
        ),
        JointDef(
            "joint_7",
            (0, -0.10593, -0.00017505),
            (-PI / 2, 0, 0),
            _Z,
            -_TWO_PI,
            _TWO_PI,
            9,
            1.2218,
            0.04,
        ),
    ),
    # The interface module's tool frame (end_effector_link).
    flange_xyz=(0, 0, -0.061525),
    flange_rpy=(PI, 0, 0),
    base_radius=0.05,
    base_height=0.1,
    link_masses=(1.3773, 1.1636, 1.1636, 0.9302, 0.6781, 0.6781, 0.364),
)

_PANDA_LIMITS = (
    ("panda_joint1", -2.8973, 2.8973),
    ("panda_joint2", -1.7628, 1.7628),
    ("panda_joint3", -2.8973, 2.8973),
    ("panda_joint4", -3.0718, -0.0698),
    ("panda_joint5", -2.8973, 2.8973),
    ("panda_joint6", -0.0175, 3.7525),
    ("panda_joint7", -2.8973, 2.8973),
)

PANDA_ARM = ShippedArm(
    urdf=PYBULLET_DATA / "franka_panda" / "panda.urdf",
    root_link="panda_link0",
    flange_link="panda_link8",
    keep_links=None,
    limits=_PANDA_LIMITS,
)

XARM6_ARM = ShippedArm(
    urdf=PYBULLET_DATA / "xarm" / "xarm6_with_gripper.urdf",
    root_link="link_base",
    flange_link="link6",
    # The xArm gripper is a six-bar linkage (closed chain, mimic joints) that PyBullet
    # cannot simulate as such: keep its palm mesh, replace the linkage by prismatic fingers.
    keep_links=("link_base", "link1", "link2", "link3", "link4", "link5", "link6"),
)
