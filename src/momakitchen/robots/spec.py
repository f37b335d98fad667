"""Robot specifications: the numbers that describe each mobile manipulator, and its model.

This registry is the single source of truth for robot names, reach and mount height; the
scene sampler (obstacle semicircles), labelling (sampling radius) and the learning code
(robot descriptor) all read it. Each entry also holds the robot's model (its URDF,
``arms.py``): a robot is registered once, numbers and build together. Every robot, built-in
or a user's, is registered from a URDF and a YAML file by one loader (``user.py``); the
built-ins' files are in ``shipped/``, their figures the manufacturers'
(``docs/ROBOTS.md``).

Importing this module does not import PyBullet (only ``pybullet_data``, a path).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

from momakitchen.errors import MomaError
from momakitchen.registry import Registry
from momakitchen.robots.arms import RobotModel

END_EFFECTORS = ("parallel_gripper", "suction")

# The mobile base's footprint (length along its x, width), m: every built-in's but the
# xArm6's, and the base of a robot given by its numbers.
DEFAULT_FOOTPRINT = (0.55, 0.45)

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
    footprint: tuple[float, float] = DEFAULT_FOOTPRINT
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
        if model.home and len(model.home) != self.dof:
            raise MomaError(
                f"robot {self.name!r}: home needs {self.dof} values, got {len(model.home)}"
            )


class RobotRegistry(Registry[RobotSpec]):
    """The robots by name: the built-ins (:data:`BUILT_IN_ROBOTS`, registered from their
    shipped URDF and YAML files by the user robots' loader the first time the registry is
    read, :meth:`load_first`) and the user robots registered since; user robots can be
    taken out again."""

    def __init__(self, kind: str) -> None:
        self._load: Callable[[], None] | None = None
        super().__init__(kind)

    def load_first(self, load: Callable[[], None]) -> None:
        """Call ``load`` (register the built-ins) the first time the registry is read.
        ``user.py`` sets it on import, and importing this module imports the package
        (``robots/__init__.py``), which imports ``user.py``: the loader is set before any
        lookup, without this module importing the loader."""
        self._load = load

    @property
    def _entries(self) -> dict[str, RobotSpec]:
        # Every read and write of the registry goes through here (Registry's methods).
        load, self._load = self._load, None
        if load is not None:
            load()
        return self._store

    @_entries.setter
    def _entries(self, value: dict[str, RobotSpec]) -> None:
        self._store = value

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


# The built-in robots, in the order they are listed: each ships as ``shipped/NAME.urdf`` (arm
# and tool) and ``shipped/NAME.yaml`` (its numbers; the manufacturers' figures,
# docs/ROBOTS.md), loaded like a user's robot. The first six are the paper's; the UR10e and
# the Gen3 widen the reach range to 0.9-1.3 m and are available by name, but not in
# DEFAULT_ROBOTS.
BUILT_IN_ROBOTS = ("panda", "flexiv", "ur5e", "xarm6", "realman", "elephant", "ur10e", "gen3")

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
# The finger force of a gripper whose force nobody gave, N.
DEFAULT_FINGER_FORCE = 40.0
# Closing forces per finger a gripper may have, N (small electric grippers give ~20 N,
# industrial ones 100-200 N). The force decides which targets can be opened at all: a
# fridge door's seal holds against 40 N fingers that slip off its handle where 80 N ones
# pull it open (docs/ROBOTS.md, "Grip force").
FORCE_RANGE = (10.0, 200.0)
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
    return float(spec.model.end_effector.finger_force)


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
