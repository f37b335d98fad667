"""User robots: a URDF (arm + tool) plus a small YAML file.

Example ``myarm.yaml`` (paths relative to the YAML file)::

    name: myarm                    # registry name, lower case
    urdf: myarm.urdf               # the arm with its tool, links below one root link
    mount_height: 0.9              # metres above the floor, on top of the mobile base
    end_effector_link: tool0       # the TCP frame (z = approach; fingers close along y)
    end_effector: parallel_gripper # or: suction
    # optional:
    reach: 0.8                     # metres; measured from the model when absent
    finger_joints: [left_finger_joint, right_finger_joint]  # default: prismatic joints
    home: [0, -1.0, 1.2, 0, 0.5, 0]  # rest configuration (IK seed), one value per joint
    footprint: [0.55, 0.45]        # base length and width in metres
    mount_offset_x: 0.0            # arm mount position along the base's x axis

The robot is mounted on the same mobile base as the built-in ones. On the command line,
``--robot-yaml FILE`` (repeatable) or the environment variable ``MOMAKITCHEN_ROBOT_YAML``
(paths separated by ``os.pathsep``) registers user robots before the command runs.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import yaml

from momakitchen.errors import MomaError
from momakitchen.fileio import existing_file
from momakitchen.robots.arms import RobotModel, ShippedArm, UserTool
from momakitchen.robots.spec import ROBOTS, RobotSpec, register_robot
from momakitchen.robots.urdf import BASE_LINK, TCP_LINK, link_of, parse_urdf

ENV_VAR = "MOMAKITCHEN_ROBOT_YAML"

_REQUIRED = {
    "name": str,
    "urdf": str,
    "mount_height": float,
    "end_effector_link": str,
    "end_effector": str,
}
_OPTIONAL = {
    "reach": float,
    "finger_joints": list,
    "home": list,
    "footprint": list,
    "mount_offset_x": float,
}
_LOADED: dict[str, str] = {}  # resolved YAML path -> robot name


@dataclass(frozen=True)
class UserRobotConfig:
    """The contents of a user robot YAML file (validated).

    Attributes:
        name: registry name.
        urdf: absolute path of the URDF.
        mount_height: arm mount height above the floor, metres.
        end_effector_link: TCP link of the URDF.
        end_effector: ``"parallel_gripper"`` or ``"suction"``.
        reach: metres, or None to measure it.
        finger_joints: gripper finger joints (prismatic), or empty for the default.
        home: rest configuration, or empty for mid-range.
        footprint: base (length, width) in metres.
        mount_offset_x: arm mount position along the base's x axis, metres.
        source: the YAML path (for error messages).
    """

    name: str
    urdf: Path
    mount_height: float
    end_effector_link: str
    end_effector: str
    reach: float | None = None
    finger_joints: tuple[str, ...] = ()
    home: tuple[float, ...] = ()
    footprint: tuple[float, float] = (0.55, 0.45)
    mount_offset_x: float = 0.0
    source: str = ""

    def __post_init__(self) -> None:
        where = self.source or "user robot"
        if self.end_effector not in ("parallel_gripper", "suction"):
            raise MomaError(
                f"{where}: end_effector must be 'parallel_gripper' or 'suction', "
                f"got {self.end_effector!r}"
            )
        if not self.name or self.name != self.name.lower() or not self.name.isidentifier():
            raise MomaError(f"{where}: name must be a lower-case identifier, got {self.name!r}")
        if len(self.footprint) != 2:
            raise MomaError(f"{where}: footprint must be [length, width], got {self.footprint}")


def _typed(value, kind, key: str, where: str):
    """Check one YAML value against the expected type; ints are fine where floats are."""
    if kind is float:
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not math.isfinite(value)
        ):
            raise MomaError(f"{where}: field {key!r} must be a number, got {value!r}")
        return float(value)
    if not isinstance(value, kind):
        raise MomaError(f"{where}: field {key!r} must be a {kind.__name__}, got {value!r}")
    return value


def load_config(path: str | os.PathLike) -> UserRobotConfig:
    """Read and validate a user robot YAML file (MomaError naming the file otherwise)."""
    path = existing_file(path, "robot YAML file")
    where = str(path)
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as exc:
        raise MomaError(f"robot YAML file {where!r} cannot be read: {exc}") from None
    except yaml.YAMLError as exc:
        detail = " ".join(str(exc).split())
        raise MomaError(f"robot YAML file {where!r} does not parse: {detail}") from None
    if not isinstance(data, dict):
        raise MomaError(f"{where}: expected a mapping of fields, got {type(data).__name__}")
    unknown = sorted(set(data) - set(_REQUIRED) - set(_OPTIONAL))
    if unknown:
        raise MomaError(
            f"{where}: unknown field(s) {unknown}; known: {sorted(_REQUIRED) + sorted(_OPTIONAL)}"
        )
    values = {}
    for key, kind in _REQUIRED.items():
        if key not in data or data[key] is None:
            raise MomaError(f"{where}: missing required field {key!r}")
        values[key] = _typed(data[key], kind, key, where)
    for key, kind in _OPTIONAL.items():
        if data.get(key) is not None:
            values[key] = _typed(data[key], kind, key, where)
    for key in ("finger_joints",):
        if key in values and not all(isinstance(v, str) for v in values[key]):
            raise MomaError(f"{where}: field {key!r} must be a list of joint names")
    for key in ("home", "footprint"):
        if key in values:
            values[key] = tuple(_typed(v, float, key, where) for v in values[key])
    if "finger_joints" in values:
        values["finger_joints"] = tuple(values["finger_joints"])
    urdf = Path(values.pop("urdf"))
    if not urdf.is_absolute():
        urdf = (path.parent / urdf).resolve()
    return UserRobotConfig(urdf=urdf, source=where, **values)


def _model(cfg: UserRobotConfig) -> tuple[RobotModel, int]:
    """Robot model of a user config and its arm DoF; checks the URDF's structure."""
    root = parse_urdf(cfg.urdf)
    where = str(cfg.urdf)
    links = [link.get("name", "") for link in root.findall("link")]
    for reserved in (BASE_LINK, TCP_LINK):
        if reserved in links:
            raise MomaError(f"URDF file {where!r}: link name {reserved!r} is reserved")
    if cfg.end_effector_link not in links:
        raise MomaError(
            f"URDF file {where!r}: no link {cfg.end_effector_link!r} "
            f"(end_effector_link in {cfg.source})"
        )
    joints = root.findall("joint")
    children = {link_of(j, "child"): j for j in joints}
    roots = [name for name in links if name not in children]
    if len(roots) != 1:
        raise MomaError(f"URDF file {where!r}: expected one root link, found {roots}")
    path, link = [], cfg.end_effector_link
    while link in children:
        path.append(children[link])
        link = link_of(children[link], "parent")
    movable = ("revolute", "continuous", "prismatic")
    for j in joints:
        if j.get("type") in ("revolute", "prismatic") and j.find("limit") is None:
            raise MomaError(f"URDF file {where!r}: joint {j.get('name')!r} has no <limit>")
    fingers = cfg.finger_joints
    if cfg.end_effector == "suction" and fingers:
        raise MomaError(
            f"{cfg.source}: finger_joints {list(fingers)} given, but "
            f"end_effector is 'suction' (finger joints belong to a gripper)"
        )
    if cfg.end_effector == "parallel_gripper" and not fingers:
        on_path = {j.get("name") for j in path}
        fingers = tuple(
            j.get("name", "")
            for j in joints
            if j.get("type") == "prismatic" and j.get("name") not in on_path
        )
        if not fingers:
            raise MomaError(
                f"{cfg.source}: a parallel_gripper needs finger_joints (no "
                f"prismatic joints outside the arm chain in {where!r})"
            )
    names = {j.get("name") for j in joints}
    missing = [f for f in fingers if f not in names]
    if missing:
        raise MomaError(f"{cfg.source}: finger_joints {missing} not in {where!r}")
    dof = sum(1 for j in path if j.get("type") in movable and j.get("name") not in fingers)
    if cfg.home and len(cfg.home) != dof:
        raise MomaError(f"{cfg.source}: home needs {dof} values (arm joints), got {len(cfg.home)}")
    model = RobotModel(
        ShippedArm(urdf=cfg.urdf, root_link=roots[0], flange_link=cfg.end_effector_link),
        UserTool(cfg.end_effector, cfg.end_effector_link, tuple(fingers)),
        home=cfg.home,
        source=f"user robot {cfg.source}",
    )
    return model, dof


def register_user_robot(path: str | os.PathLike) -> RobotSpec:
    """Register the robot described by a YAML file; returns its spec.

    Registering the same file again is a no-op; a name already taken by another robot is
    an error. Without ``reach`` in the YAML, the reach is measured: the farthest TCP
    distance from the shoulder (second arm joint) over sampled configurations.
    """
    key = str(Path(path).resolve())
    if key in _LOADED:
        return ROBOTS[_LOADED[key]]
    cfg = load_config(path)
    if cfg.name in ROBOTS:
        raise MomaError(f"{cfg.source}: robot name {cfg.name!r} is already registered")
    model, dof = _model(cfg)

    def make_spec(reach: float) -> RobotSpec:
        try:
            return RobotSpec(
                cfg.name,
                reach=reach,
                mount_height=cfg.mount_height,
                dof=dof,
                end_effector=cfg.end_effector,
                footprint=(cfg.footprint[0], cfg.footprint[1]),
                mount_offset_x=cfg.mount_offset_x,
                model=model,
            )
        except MomaError as exc:
            raise MomaError(f"{cfg.source}: {exc}") from None

    # Registered with a provisional reach when it is to be measured: measuring loads the
    # robot by name.
    spec = register_robot(make_spec(cfg.reach if cfg.reach is not None else 1.0))
    try:
        if cfg.reach is None:
            spec = register_robot(make_spec(round(_measure_reach(cfg.name), 3)), replace=True)
    except BaseException:
        ROBOTS.unregister(cfg.name)
        raise
    _LOADED[key] = cfg.name
    return spec


def _measure_reach(name: str) -> float:
    from momakitchen.bullet import p
    from momakitchen.robots.reach import measure_workspace
    from momakitchen.robots.robot import Robot

    client = p.connect(p.DIRECT)
    try:
        robot = Robot(client, name)
        return measure_workspace(robot, 1500)[1]
    finally:
        p.disconnect(client)


def load_env_robots() -> list[RobotSpec]:
    """Register the robots listed in ``$MOMAKITCHEN_ROBOT_YAML`` (os.pathsep-separated)."""
    paths = [s for s in os.environ.get(ENV_VAR, "").split(os.pathsep) if s.strip()]
    return [register_user_robot(s) for s in paths]


def unregister_user_robot(name: str) -> None:
    """Remove a user robot from the registries (built-in robots cannot be removed)."""
    from momakitchen.robots.robot import forget_caches

    if name not in _LOADED.values():
        raise MomaError(f"{name!r} is not a registered user robot")
    for key in [k for k, v in _LOADED.items() if v == name]:
        del _LOADED[key]
    ROBOTS.unregister(name)
    forget_caches(name)
