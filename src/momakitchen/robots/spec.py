"""Robot specifications: the numbers that describe each mobile manipulator, and its model.

This registry is the single source of truth for robot names, reach and mount height; the
scene sampler (obstacle semicircles), labelling (sampling radius) and the learning code
(robot descriptor) all read it. Each entry also holds the robot's model (how its URDF is
built, ``arms.py``): a robot is registered once, numbers and build together. Figures are
the manufacturers' (``docs/ROBOTS.md``).

Importing this module does not import PyBullet (only ``pybullet_data``, a path).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

from momakitchen.errors import MomaError
from momakitchen.registry import Registry
from momakitchen.robots.arms import (
    ELEPHANT_ARM,
    FLEXIV_ARM,
    GEN3_ARM,
    PANDA_ARM,
    PI,
    PYBULLET_DATA,
    REALMAN_ARM,
    UR5E_ARM,
    UR10E_ARM,
    XARM6_ARM,
    BuiltArm,
    ParallelGripper,
    RobotModel,
    SuctionCup,
)
from momakitchen.robots.grip import grip_model, parse_grip_name
from momakitchen.robots.scaled import parse_scaled_name, scaled_model

END_EFFECTORS = ("parallel_gripper", "suction")

# Heights (m above the floor) at which any arm may be mounted on the mobile base: from just
# below the base box's top (0.33 m) to a tall pillar. A robot's own mount height, a range to
# sample from and a generation config's mount height must all lie in it.
MOUNT_RANGE = (0.30, 1.30)


def mount_height_problem(value: object) -> str | None:
    """Why ``value`` is not a mount height (a number in :data:`MOUNT_RANGE`), or None."""
    lo, hi = MOUNT_RANGE
    if (
        isinstance(value, bool)
        or not isinstance(value, int | float)
        or not math.isfinite(value)
        or not lo <= value <= hi
    ):
        return f"mount_height must be in [{lo}, {hi}] m, got {value!r}"
    return None


def mount_range_problem(value: object) -> str | None:
    """Why ``value`` is not a mount height range ``(lo, hi)`` within :data:`MOUNT_RANGE` with
    ``lo <= hi``, or None."""
    if not isinstance(value, tuple | list) or len(value) != 2:
        return f"a mount height range must be [lo, hi], got {value!r}"
    for v in value:
        problem = mount_height_problem(v)
        if problem:
            return f"{problem} (in the range {list(value)})"
    if value[0] > value[1]:
        return f"a mount height range needs lo <= hi, got {list(value)}"
    return None


@dataclass(frozen=True)
class RobotSpec:
    """A mobile manipulator as the rest of the pipeline sees it.

    Attributes:
        name: registry key, lower case.
        reach: manufacturer's arm reach in metres (sampling radius for labels).
        mount_height: height of the arm base above the floor in metres.
        dof: number of arm joints.
        end_effector: one of ``END_EFFECTORS``.
        footprint: base footprint (length along x, width along y) in metres.
        mount_offset_x: position of the arm mount along the base's x axis (forward) from
            the base centre, metres.
        mount_range: ``(lo, hi)`` metres: generation samples the mount height of each
            configuration in this range (``mount_height`` is then the nominal one, e.g. for
            ``predict``); None: always ``mount_height``. Keyword only.
        model: how the robot is built (arm, end-effector, home pose); keyword only.
    """

    name: str
    reach: float
    mount_height: float
    dof: int
    end_effector: str
    footprint: tuple[float, float] = (0.55, 0.45)
    mount_offset_x: float = 0.0
    mount_range: tuple[float, float] | None = field(default=None, kw_only=True)
    model: RobotModel = field(kw_only=True, repr=False)

    def __post_init__(self) -> None:
        if not self.name or self.name != self.name.lower():
            raise MomaError(f"robot name must be non-empty lower case, got {self.name!r}")
        if not 0.1 <= self.reach <= 3.0:
            raise MomaError(f"robot {self.name!r}: reach must be in [0.1, 3] m, got {self.reach}")
        problem = mount_height_problem(self.mount_height)
        if problem:
            raise MomaError(f"robot {self.name!r}: {problem}")
        if self.mount_range is not None:
            problem = mount_range_problem(self.mount_range)
            if problem:
                raise MomaError(f"robot {self.name!r}: {problem}")
            lo, hi = self.mount_range
            object.__setattr__(self, "mount_range", (float(lo), float(hi)))
            if not lo <= self.mount_height <= hi:
                raise MomaError(
                    f"robot {self.name!r}: mount_height {self.mount_height} lies outside its "
                    f"mount_range {list(self.mount_range)}"
                )
        if not 3 <= self.dof <= 10:
            raise MomaError(f"robot {self.name!r}: dof must be in [3, 10], got {self.dof}")
        if self.end_effector not in END_EFFECTORS:
            raise MomaError(
                f"robot {self.name!r}: end_effector must be one of {END_EFFECTORS}, "
                f"got {self.end_effector!r}"
            )
        if any(not 0.1 <= f <= 2.0 for f in self.footprint):
            raise MomaError(
                f"robot {self.name!r}: footprint must be in [0.1, 2] m, got {self.footprint}"
            )
        if abs(self.mount_offset_x) > self.footprint[0] / 2:
            raise MomaError(
                f"robot {self.name!r}: mount_offset_x must lie on the base (|x| <= "
                f"{self.footprint[0] / 2}), got {self.mount_offset_x}"
            )
        self._check_model()

    @property
    def mount_heights(self) -> tuple[float, float]:
        """``(lo, hi)``: the mount heights this robot may have (one value twice if fixed)."""
        return self.mount_range or (self.mount_height, self.mount_height)

    def _check_model(self) -> None:
        """The model must build the robot the numbers describe."""
        model = self.model
        if not isinstance(model, RobotModel):
            raise MomaError(
                f"robot {self.name!r}: model must be a RobotModel, got {type(model).__name__}"
            )
        if model.tool_kind != self.end_effector:
            raise MomaError(
                f"robot {self.name!r}: end_effector {self.end_effector!r} but its "
                f"model's tool is a {model.tool_kind!r}"
            )
        if isinstance(model.arm, BuiltArm) and len(model.arm.joints) != self.dof:
            raise MomaError(
                f"robot {self.name!r}: dof={self.dof} but its arm has "
                f"{len(model.arm.joints)} joints"
            )
        if model.home and len(model.home) != self.dof:
            raise MomaError(
                f"robot {self.name!r}: home needs {self.dof} values, got {len(model.home)}"
            )


class RobotRegistry(Registry[RobotSpec]):
    """The robots by name; user robots can also be taken out again.

    A name of the form ``NAME-xS.SS`` not yet registered is a built-in arm with scaled
    links (``scaled.py``), one of the form ``NAME-fN`` robot ``NAME`` with fingers of
    ``N`` newtons (``grip.py``): each is built and registered the first time it is asked
    for.
    """

    def get_entry(self, name: str) -> RobotSpec:
        if isinstance(name, str) and name not in self._entries:
            scaled = parse_scaled_name(name)
            if scaled is not None and scaled[0] in self._entries:
                base, scale = self._entries[scaled[0]], scaled[1]
                model = scaled_model(name, base.model, scale)
                reach = round(base.reach * scale, 4)
                return self.register(dataclasses.replace(base, name=name, reach=reach, model=model))
            grip = parse_grip_name(name)
            if grip is not None and self._known(grip[0]):
                base = self.get_entry(grip[0])
                model = grip_model(name, base.model, grip[1])
                return self.register(dataclasses.replace(base, name=name, model=model))
        return super().get_entry(name)

    def _known(self, name: str) -> bool:
        """Whether ``name`` is registered or can be built from its name."""
        if name in self._entries:
            return True
        scaled = parse_scaled_name(name)
        return scaled is not None and scaled[0] in self._entries

    def unregister(self, name: str) -> None:
        """Remove ``name`` if registered (user robots; the caller checks which)."""
        self._entries.pop(name, None)


ROBOTS: RobotRegistry = RobotRegistry("robot")


def register_robot(spec: RobotSpec, *, replace: bool = False) -> RobotSpec:
    """Add ``spec`` (with its model) to the registry; refuses to silently replace a name.

    The one way a robot, built-in or user, becomes known.
    """
    return ROBOTS.register(spec, replace=replace)


def get_robot_spec(name: str) -> RobotSpec:
    """Look up a robot by name; unknown names raise MomaError listing the known ones."""
    return ROBOTS.get_entry(name)


# Arms stand on the front half of the base, as on most mobile manipulators: a base meets a
# counter with its front edge, and a centred arm would lose 0.15 m of its reach to it.
FRONT_MOUNT = 0.15

# Manufacturer figures (docs/ROBOTS.md, "Mounting and descriptors"). Reach as in the
# MoMa-Kitchen reference code where it gives one.
for _spec in (
    RobotSpec(
        "panda",
        reach=0.85,
        mount_height=1.03,
        dof=7,
        end_effector="parallel_gripper",
        mount_offset_x=FRONT_MOUNT,
        model=RobotModel(
            PANDA_ARM,
            # Franka Hand: fingers 0-0.04 m each, grasp centre 0.1034 m beyond the flange.
            ParallelGripper(
                tcp_offset=0.1034,
                max_opening=0.08,
                yaw=-PI / 4,
                finger_force=70.0,
                existing_fingers=("panda_finger_joint1", "panda_finger_joint2"),
            ),
            home=(0.0, 0.2, 0.0, -2.5, 0.0, 2.7, PI / 4),
            source="pybullet_data/franka_panda/panda.urdf (Franka Emika), published limits",
        ),
    ),
    RobotSpec(
        "flexiv",
        reach=0.78,
        mount_height=1.03,
        dof=7,
        end_effector="parallel_gripper",
        mount_offset_x=FRONT_MOUNT,
        model=RobotModel(
            FLEXIV_ARM,
            # Robotiq 2F-85-like gripper (what BestMan mounted), 8 cm opening; the
            # 2F-85 grips with 20-235 N: 100 N per finger.
            ParallelGripper(tcp_offset=0.15, palm_size=(0.07, 0.14, 0.10), finger_force=100.0),
            home=(0.0, -0.7, 0.0, 1.6, 0.0, 0.8, 0.0),
            source="Flexiv SDK kinematics URDF (Rizon 4)",
        ),
    ),
    RobotSpec(
        "ur5e",
        reach=0.85,
        mount_height=1.03,
        dof=6,
        end_effector="suction",
        mount_offset_x=FRONT_MOUNT,
        model=RobotModel(
            UR5E_ARM,
            SuctionCup(tcp_offset=0.134),
            home=(0.0, -1.9, 1.9, -1.57, -1.57, 0.0),
            source="Universal Robots nominal kinematics (DH table), ROS description chain",
        ),
    ),
    RobotSpec(
        "xarm6",
        reach=0.70,
        mount_height=0.33,
        dof=6,
        end_effector="parallel_gripper",
        footprint=(0.60, 0.48),
        mount_offset_x=FRONT_MOUNT,
        model=RobotModel(
            XARM6_ARM,
            # xArm gripper palm (shipped mesh) with prismatic fingers, TCP 0.172 m.
            ParallelGripper(
                tcp_offset=0.172,
                palm_size=(0.06, 0.12, 0.11),
                finger_size=(0.022, 0.012, 0.05),
                palm_mesh=PYBULLET_DATA / "xarm" / "xarm_gripper" / "meshes" / "base_link.STL",
            ),
            home=(0.0, 0.26, -0.85, 0.0, 0.59, 0.0),
            source="pybullet_data/xarm/xarm6_with_gripper.urdf (UFACTORY)",
        ),
    ),
    RobotSpec(
        "realman",
        reach=0.90,
        mount_height=1.03,
        dof=6,
        end_effector="parallel_gripper",
        mount_offset_x=FRONT_MOUNT,
        model=RobotModel(
            REALMAN_ARM,
            # DH Robotics AG-95-like gripper (what BestMan mounted), 8 cm opening; the
            # AG-95 grips with 45-160 N: 80 N per finger.
            ParallelGripper(tcp_offset=0.16, palm_size=(0.07, 0.13, 0.11), finger_force=80.0),
            home=(0.0, 0.6, 1.5, 0.0, 1.0, 0.0),
            source="Realman ROS 2 description (RML63-6F)",
        ),
    ),
    RobotSpec(
        "elephant",
        reach=0.63,
        mount_height=1.03,
        dof=6,
        end_effector="parallel_gripper",
        mount_offset_x=FRONT_MOUNT,
        model=RobotModel(
            ELEPHANT_ARM,
            ParallelGripper(tcp_offset=0.13),
            home=(0.0, -1.24, -0.77, -1.14, 1.72, -1.57),
            source="Elephant Robotics ROS description (myCobot Pro 630)",
        ),
    ),
    # Arms beyond the paper's six (docs/ROBOTS.md, "More arms"): they widen the reach range
    # to 0.9-1.3 m and are available by name, but not in DEFAULT_ROBOTS.
    RobotSpec(
        "ur10e",
        reach=1.30,
        # A long arm on a low platform: it reaches the lowest drawers and the wall cabinets.
        mount_height=0.80,
        dof=6,
        end_effector="parallel_gripper",
        mount_offset_x=FRONT_MOUNT,
        model=RobotModel(
            UR10E_ARM,
            # Robotiq 2F-85-like gripper (as on the Flexiv): 8 cm opening, 100 N per finger.
            ParallelGripper(tcp_offset=0.15, palm_size=(0.07, 0.14, 0.10), finger_force=100.0),
            home=(0.0, -1.9, 1.9, -1.57, -1.57, 0.0),
            source="Universal Robots DH table (UR10e), ROS description chain",
        ),
    ),
    RobotSpec(
        "gen3",
        reach=0.902,
        # A light arm on a low platform: its shoulder stands at counter height.
        mount_height=0.60,
        dof=7,
        end_effector="parallel_gripper",
        mount_offset_x=FRONT_MOUNT,
        model=RobotModel(
            GEN3_ARM,
            # Robotiq 2F-85 (Kinova's gripper option for the Gen3): 100 N per finger.
            ParallelGripper(tcp_offset=0.15, palm_size=(0.07, 0.14, 0.10), finger_force=100.0),
            # Kinova's "Home" position (user guide): 0, 15, 180, 230, 0, 55, 90 degrees.
            home=(0.0, 0.2618, PI, -2.2689, 0.0, 0.9599, PI / 2),
            source="Kinova Gen3 7-DoF: user guide DH table, kortex_description joint origins",
        ),
    ),
):
    register_robot(_spec)

# The robots a generation config without ``scene.robots`` assigns (the paper's six, in this
# order): every dataset made before the other arms existed keeps its bytes.
DEFAULT_ROBOTS = ("panda", "flexiv", "ur5e", "xarm6", "realman", "elephant")


# Robot descriptor for learning. Versioned: a model trained on one descriptor layout must
# not silently receive another. Each layout extends the one before, so a model of an
# older version reads the first columns of a newer descriptor, and data stored with an
# older one gain the new columns from the robot's spec when they are read
# (``momakitchen.robots.descriptor``).
DESCRIPTOR_LAYOUTS: dict[int, tuple[str, ...]] = {
    1: ("reach_m", "mount_height_m", "dof_over_7", "is_suction"),
    # The fingers' closing force decides which targets can be opened at all (a fridge
    # door's seal): robots alike in reach and mount differ in it (docs/ROBOTS.md).
    2: ("reach_m", "mount_height_m", "dof_over_7", "is_suction", "finger_force_per_100n"),
    # Where the shoulder stands: arms alike in all of the above stand it up to 11 cm apart
    # in height, or a few cm off the first joint's axis (robots/shoulder.py).
    3: (
        "reach_m",
        "mount_height_m",
        "dof_over_7",
        "is_suction",
        "finger_force_per_100n",
        "shoulder_height_m",
        "shoulder_offset_per_10cm",
    ),
}
DESCRIPTOR_VERSION = max(DESCRIPTOR_LAYOUTS)
DESCRIPTOR_NAMES = DESCRIPTOR_LAYOUTS[DESCRIPTOR_VERSION]
DESCRIPTOR_DIM = len(DESCRIPTOR_NAMES)
# The finger force of a gripper whose force nobody gave (the built grippers' default), N.
DEFAULT_FINGER_FORCE = 40.0
# The shoulder of an arm given by its numbers only, m above its mount and off joint 1's
# axis: about the middle of the registry's arms (0.16-0.37 m, docs/ROBOTS.md).
DEFAULT_SHOULDER_RISE = 0.25
DEFAULT_SHOULDER_OFFSET = 0.0


def descriptor_dim(version: object) -> int:
    """The length of a version-``version`` descriptor; MomaError for an unknown version."""
    if isinstance(version, bool) or version not in DESCRIPTOR_LAYOUTS:
        raise MomaError(
            f"robot descriptor version {version!r} is unknown; this version of momakitchen "
            f"knows {sorted(DESCRIPTOR_LAYOUTS)}"
        )
    return len(DESCRIPTOR_LAYOUTS[version])


def finger_force(spec: RobotSpec) -> float:
    """Closing force per finger of the robot's gripper in N; 0 for a suction cup."""
    if spec.end_effector == "suction":
        return 0.0
    return float(getattr(spec.model.end_effector, "finger_force", DEFAULT_FINGER_FORCE))


def descriptor_values(
    reach: float,
    mount_height: float,
    dof: float,
    suction: bool,
    finger_force: float = DEFAULT_FINGER_FORCE,
    shoulder_rise: float = DEFAULT_SHOULDER_RISE,
    shoulder_offset: float = DEFAULT_SHOULDER_OFFSET,
) -> tuple[float, ...]:
    """The descriptor of a robot given by its numbers (one not in the registry);
    ``finger_force`` in N per finger, ignored for suction; ``shoulder_rise`` and
    ``shoulder_offset`` in m, the shoulder's height above the mount and its distance from
    the first joint's axis."""
    force = 0.0 if suction else float(finger_force) / 100.0
    return (
        float(reach),
        float(mount_height),
        dof / 7.0,
        1.0 if suction else 0.0,
        force,
        float(mount_height) + float(shoulder_rise),
        float(shoulder_offset) * 10.0,
    )
