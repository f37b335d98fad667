"""Robot specifications: the numbers that describe each mobile manipulator.

This registry is the single source of truth for robot names, reach and mount height; the
scene sampler (obstacle semicircles), labelling (sampling radius) and the learning code
(robot descriptor) all read it. Figures are the manufacturers' (``shared/robots/KINEMATICS.md``).
"""

from __future__ import annotations

from dataclasses import dataclass

from momakitchen.errors import MomaError

END_EFFECTORS = ("parallel_gripper", "suction")


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
    """

    name: str
    reach: float
    mount_height: float
    dof: int
    end_effector: str
    footprint: tuple[float, float] = (0.55, 0.45)
    mount_offset_x: float = 0.0

    def __post_init__(self) -> None:
        if not self.name or self.name != self.name.lower():
            raise MomaError(f"robot name must be non-empty lower case, got {self.name!r}")
        if not 0.1 <= self.reach <= 3.0:
            raise MomaError(f"robot {self.name!r}: reach must be in [0.1, 3] m, got {self.reach}")
        if not 0.0 <= self.mount_height <= 2.5:
            raise MomaError(
                f"robot {self.name!r}: mount_height must be in [0, 2.5] m, got {self.mount_height}"
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


ROBOTS: dict[str, RobotSpec] = {}


def register_robot(spec: RobotSpec, *, replace: bool = False) -> RobotSpec:
    """Add ``spec`` to the registry; refuses to silently replace an existing name."""
    if spec.name in ROBOTS and not replace:
        raise MomaError(f"robot {spec.name!r} is already registered")
    ROBOTS[spec.name] = spec
    return spec


def get_robot_spec(name: str) -> RobotSpec:
    """Look up a robot by name; unknown names raise MomaError listing the known ones."""
    try:
        return ROBOTS[name]
    except KeyError:
        raise MomaError(f"unknown robot {name!r}; known robots: {', '.join(ROBOTS)}") from None


# Arms stand on the front half of the base, as on most mobile manipulators: a base meets a
# counter with its front edge, and a centred arm would lose 0.15 m of its reach to it.
FRONT_MOUNT = 0.15

# Manufacturer figures (KINEMATICS.md, "Mounting and descriptors"). Reach as in the
# MoMa-Kitchen reference code where it gives one.
for _spec in (
    RobotSpec("panda", reach=0.85, mount_height=1.03, dof=7, end_effector="parallel_gripper",
              mount_offset_x=FRONT_MOUNT),
    RobotSpec("flexiv", reach=0.78, mount_height=1.03, dof=7, end_effector="parallel_gripper",
              mount_offset_x=FRONT_MOUNT),
    RobotSpec("ur5e", reach=0.85, mount_height=1.03, dof=6, end_effector="suction",
              mount_offset_x=FRONT_MOUNT),
    RobotSpec(
        "xarm6", reach=0.70, mount_height=0.33, dof=6, end_effector="parallel_gripper",
        footprint=(0.60, 0.48), mount_offset_x=FRONT_MOUNT,
    ),
    RobotSpec("realman", reach=0.90, mount_height=1.03, dof=6, end_effector="parallel_gripper",
              mount_offset_x=FRONT_MOUNT),
    RobotSpec("elephant", reach=0.63, mount_height=1.03, dof=6, end_effector="parallel_gripper",
              mount_offset_x=FRONT_MOUNT),
):
    register_robot(_spec)


# Robot descriptor for learning. Version it: a model trained on one descriptor layout must
# not silently receive another.
DESCRIPTOR_VERSION = 1
DESCRIPTOR_NAMES = ("reach_m", "mount_height_m", "dof_over_7", "is_suction")
DESCRIPTOR_DIM = len(DESCRIPTOR_NAMES)


def robot_descriptor(spec: RobotSpec) -> tuple[float, ...]:
    """The robot as numbers for the model, in the order of ``DESCRIPTOR_NAMES``.

    The first two entries are the paper's descriptor ``[reach, mount height]``.
    """
    return descriptor_values(spec.reach, spec.mount_height, spec.dof,
                             spec.end_effector == "suction")


def descriptor_values(reach: float, mount_height: float, dof: int, suction: bool
                      ) -> tuple[float, ...]:
    """The descriptor of a robot given by its numbers (one not in the registry)."""
    return (float(reach), float(mount_height), dof / 7.0, 1.0 if suction else 0.0)
