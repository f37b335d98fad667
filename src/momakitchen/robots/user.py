"""User robots: a URDF (arm + tool) plus a small YAML file.

Example ``myarm.yaml`` (paths relative to the YAML file)::

    name: myarm                    # registry name, lower case
    urdf: myarm.urdf               # the arm with its tool, links below one root link
    mount_height: 0.9              # metres above the floor, on top of the mobile base;
                                   # or [lo, hi]: sampled per configuration by `generate`
    end_effector_link: tool0       # the TCP frame (z = approach; fingers close along y)
    end_effector: parallel_gripper # or: suction
    # optional:
    reach: 0.8                     # metres; measured from the model when absent
    finger_joints: [left_finger_joint, right_finger_joint]  # default: prismatic joints
    home: [0, -1.0, 1.2, 0, 0.5, 0]  # rest configuration (IK seed), one value per joint
    footprint: [0.55, 0.45]        # base length and width in metres
    mount_offset_x: 0.0            # arm mount position along the base's x axis
    mount_yaw: 0.0                 # the arm's rotation on the base about the vertical, rad
    flange_link: tool_flange       # the wrist's flange (reach checks); default: a link
                                   # named "flange", else end_effector_link
    finger_force: 40.0             # closing force per finger, N (grippers; default 40)
    suction_face_tolerance: 0.008  # suction: how far behind the TCP plane a contact still
                                   # counts as on the cup's face, m (default 0.008)
    link_scale: 1.0                # every length of the arm (not the tool) times this
    source: "maker's DH table"     # where the figures come from

A robot like a built-in one needs only what differs: ``like: ur5e`` starts from the
built-in's files (``shipped/ur5e.yaml`` and its URDF), and the fields given replace its
own; ``name`` is still required. For example a UR5e with links 0.65 times as long::

    name: ur5e_x065
    like: ur5e
    link_scale: 0.65
    # reach: the built-in's times link_scale unless given

The YAML file may be at most :data:`MAX_YAML_BYTES` (1 MB): its fields are a few lines,
and a larger file is refused before it is parsed. The URDF must be a tree: one root
link, every other link the child of exactly one joint, no loops.

The robot is mounted on the same mobile base as the built-in ones, at any height of
:data:`~momakitchen.robots.spec.MOUNT_RANGE`. On the command line, ``--robot-yaml FILE``
(repeatable; a directory: each of its ``*.yaml`` files) or the environment variable
``MOMAKITCHEN_ROBOT_YAML`` (paths separated by ``os.pathsep``) registers user robots
before the command runs. Each registered file is
known with the content hash of the YAML and its URDF (:func:`user_robot_file`): datasets
record it, and generation's worker processes register the same files and check the hash.
"""

from __future__ import annotations

import dataclasses
import difflib
import hashlib
import math
import os
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import yaml

from momakitchen.errors import MomaError
from momakitchen.fileio import existing_file
from momakitchen.robots.arms import RobotModel, UrdfArm, UrdfTool
from momakitchen.robots.scaled import scale_problem
from momakitchen.robots.spec import (
    BUILT_IN_ROBOTS,
    DEFAULT_FINGER_FORCE,
    FORCE_RANGE,
    ROBOTS,
    RobotSpec,
    mount_height_problem,
    mount_range_problem,
    register_robot,
)
from momakitchen.robots.urdf import BASE_LINK, TCP_LINK, link_of, parse_urdf

if TYPE_CHECKING:
    from momakitchen.robots.body import RobotBody

ENV_VAR = "MOMAKITCHEN_ROBOT_YAML"
# The built-in robots' files: ``NAME.yaml`` and the URDF it names, for each name of
# ``spec.BUILT_IN_ROBOTS``.
SHIPPED = Path(__file__).resolve().parent / "shipped"
# Heights above the floor (m) between which the kitchens place what a robot manipulates,
# from low drawers and bins to the wall cabinets' shelves: a tool must reach into them.
TARGET_HEIGHTS = (0.1, 2.0)
# A robot's YAML is a few hundred bytes; parsing a huge one (a list of millions of items)
# would take minutes, so a larger file is refused unparsed.
MAX_YAML_BYTES = 1024 * 1024
# Joints that build_urdf adds around a user's URDF: the arm's mount and, above a TCP link
# not named "tcp", the TCP frame's (PyBullet crashes on a URDF with two joints of one name).
RESERVED_JOINTS = ("mount_joint", "tcp_joint")
# How many of a URDF's names an error lists when the YAML names one it does not have.
_LISTED = 8

_REQUIRED: dict[str, type] = {
    "name": str,
    "urdf": str,
    "mount_height": object,  # a number or [lo, hi] (checked apart)
    "end_effector_link": str,
    "end_effector": str,
}
_OPTIONAL: dict[str, type] = {
    "like": str,
    "reach": float,
    "finger_joints": list,
    "home": list,
    "footprint": list,
    "mount_offset_x": float,
    "mount_yaw": float,
    "flange_link": str,
    "finger_force": float,
    "suction_face_tolerance": float,
    "link_scale": float,
    "source": str,
}
_LOADED: dict[str, str] = {}  # resolved YAML path -> robot name


@dataclass(frozen=True)
class UserRobotFile:
    """Where a registered user robot comes from.

    Attributes:
        name: the robot's registry name.
        yaml: the resolved path of its YAML file.
        sha256: hex digest of the YAML file's bytes followed by its URDF's bytes (and
            between them, for a YAML ``like`` a built-in, the built-in's YAML;
            :func:`robot_files_digest`): the same text gives the same robot.
    """

    name: str
    yaml: str
    sha256: str

    def to_dict(self) -> dict[str, str]:
        return {"name": self.name, "yaml": self.yaml, "sha256": self.sha256}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], where: str = "user robot record") -> UserRobotFile:
        """Inverse of :meth:`to_dict`; MomaError naming ``where`` on a malformed record."""
        if not isinstance(data, Mapping) or not all(
            isinstance(data.get(k), str) and data.get(k) for k in ("name", "yaml", "sha256")
        ):
            raise MomaError(f"{where}: expected {{'name', 'yaml', 'sha256'}} strings, got {data!r}")
        return cls(str(data["name"]), str(data["yaml"]), str(data["sha256"]))


_FILES: dict[str, UserRobotFile] = {}  # robot name -> its files


def is_robot_name(name: str) -> bool:
    """Whether ``name`` can name a user robot: a lower-case identifier."""
    return bool(name) and name == name.lower() and name.isidentifier()


@dataclass(frozen=True)
class UserRobotConfig:
    """The contents of a user robot YAML file (validated).

    Attributes:
        name: registry name.
        urdf: absolute path of the URDF.
        mount_height: arm mount height above the floor, metres (the nominal one, the middle
            of ``mount_range``, when a range is given).
        mount_range: ``(lo, hi)`` metres when the YAML gives ``mount_height: [lo, hi]``
            (sampled per configuration by generation), else None.
        end_effector_link: TCP link of the URDF.
        end_effector: ``"parallel_gripper"`` or ``"suction"``.
        reach: metres, or None to measure it.
        finger_joints: gripper finger joints (prismatic), or empty for the default.
        home: rest configuration, or empty for mid-range.
        footprint: base (length, width) in metres.
        mount_offset_x: arm mount position along the base's x axis, metres.
        mount_yaw: rotation of the URDF's root link about the vertical on the base, radians
            in [-2 pi, 2 pi] (turns an arm whose joint 1 at 0 points backwards forward).
        flange_link: the link whose frame is the wrist's flange (IK's reach pre-check), or
            "" for the default (a link named ``flange``, else ``end_effector_link``).
        finger_force: closing force per finger of a gripper, N (in
            ``spec.FORCE_RANGE``; it decides e.g. whether a fridge door opens), or None
            for the default (``DEFAULT_FINGER_FORCE``); grippers only.
        suction_face_tolerance: how far behind the TCP's xy plane a contact still counts
            as on a suction cup's face, m, or None for the default (0.008); suction only.
        link_scale: every length of the arm is multiplied by this (``scaled.py``).
        like: the built-in robot whose files this one starts from, or "".
        provenance: where the figures come from (the YAML's ``source``), or "".
        source: the YAML path (for error messages).
    """

    name: str
    urdf: Path
    mount_height: float
    end_effector_link: str
    end_effector: str
    mount_range: tuple[float, float] | None = None
    reach: float | None = None
    finger_joints: tuple[str, ...] = ()
    home: tuple[float, ...] = ()
    footprint: tuple[float, float] = (0.55, 0.45)
    mount_offset_x: float = 0.0
    mount_yaw: float = 0.0
    flange_link: str = ""
    finger_force: float | None = None
    suction_face_tolerance: float | None = None
    link_scale: float = 1.0
    like: str = ""
    provenance: str = ""
    source: str = ""

    def __post_init__(self) -> None:
        where = self.source or "user robot"
        if self.end_effector not in ("parallel_gripper", "suction"):
            raise MomaError(
                f"{where}: end_effector must be 'parallel_gripper' or 'suction', "
                f"got {self.end_effector!r}"
            )
        if not is_robot_name(self.name):
            raise MomaError(f"{where}: name must be a lower-case identifier, got {self.name!r}")
        if len(self.footprint) != 2:
            raise MomaError(f"{where}: footprint must be [length, width], got {self.footprint}")
        problem = mount_height_problem(self.mount_height)
        if problem is None and self.mount_range is not None:
            problem = mount_range_problem(self.mount_range)
        if problem:
            raise MomaError(f"{where}: {problem}")
        if not abs(self.mount_yaw) <= 2 * math.pi:
            raise MomaError(
                f"{where}: mount_yaw must be in [-2 pi, 2 pi] rad, got {self.mount_yaw}"
            )
        problem = scale_problem(self.link_scale)
        if problem:
            raise MomaError(f"{where}: {problem}")
        if self.suction_face_tolerance is not None:
            if self.end_effector != "suction":
                raise MomaError(
                    f"{where}: suction_face_tolerance is for suction cups; end_effector is "
                    f"{self.end_effector!r}"
                )
            if not 0.0 < self.suction_face_tolerance <= 0.05:
                raise MomaError(
                    f"{where}: suction_face_tolerance must be in (0, 0.05] m, "
                    f"got {self.suction_face_tolerance:g}"
                )
        if self.finger_force is not None:
            lo, hi = FORCE_RANGE
            if self.end_effector == "suction":
                raise MomaError(f"{where}: finger_force is for grippers; end_effector is 'suction'")
            if not lo <= self.finger_force <= hi:
                raise MomaError(
                    f"{where}: finger_force must be in [{lo:g}, {hi:g}] N, "
                    f"got {self.finger_force:g}"
                )


def _typed(value, kind, key: str, where: str):
    """Check one YAML value against the expected type; ints are fine where floats are."""
    if kind is object:
        return value
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


def _read_yaml(path: Path) -> dict[str, Any]:
    """The fields of robot YAML file ``path`` (at most :data:`MAX_YAML_BYTES`), unchecked;
    MomaError naming the file when it cannot be read or parsed or is not a mapping."""
    where = str(path)
    try:
        with path.open("rb") as f:
            raw = f.read(MAX_YAML_BYTES + 1)  # never more, whatever the file claims
        if len(raw) > MAX_YAML_BYTES:
            size = path.stat().st_size
            raise MomaError(
                f"robot YAML file {where!r} is {size} bytes, over the limit of "
                f"{MAX_YAML_BYTES} bytes (1 MB): a robot's YAML is a few lines"
            )
        data = yaml.safe_load(raw.decode("utf-8"))
    except (OSError, UnicodeDecodeError) as exc:
        raise MomaError(f"robot YAML file {where!r} cannot be read: {exc}") from None
    except yaml.YAMLError as exc:
        detail = " ".join(str(exc).split())
        raise MomaError(f"robot YAML file {where!r} does not parse: {detail}") from None
    if not isinstance(data, dict):
        raise MomaError(f"{where}: expected a mapping of fields, got {type(data).__name__}")
    return data


def shipped_yaml(name: str) -> Path:
    """The YAML file of built-in robot ``name`` (in ``shipped/``)."""
    return SHIPPED / f"{name}.yaml"


def _like(data: dict[str, Any], where: str) -> dict[str, Any]:
    """The fields of a YAML that says ``like: NAME``: the built-in's, replaced by those the
    file gives (its URDF path made absolute). A ``link_scale`` without a ``reach`` scales
    the built-in's reach."""
    like = data["like"]
    if like not in BUILT_IN_ROBOTS:
        raise MomaError(
            f"{where}: field 'like' must name a built-in robot ({', '.join(BUILT_IN_ROBOTS)}), "
            f"got {like!r}"
        )
    base = _read_yaml(shipped_yaml(like))
    merged = {k: v for k, v in base.items() if k != "name"}
    merged["urdf"] = str(SHIPPED / base["urdf"])
    if "link_scale" in data and "reach" not in data and "reach" in base:
        scale = _typed(data["link_scale"], float, "link_scale", where)
        merged["reach"] = round(base["reach"] * scale, 4)
    merged.update(data)
    return merged


def load_config(path: str | os.PathLike) -> UserRobotConfig:
    """Read and validate a user robot YAML file (MomaError naming the file otherwise)."""
    path = existing_file(path, "robot YAML file")
    where = str(path)
    data = _read_yaml(path)
    if data.get("like") is not None:
        data = _like(data, where)
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
    values["mount_height"], values["mount_range"] = _mount(values["mount_height"], where)
    values["provenance"] = values.pop("source", "")
    urdf = Path(values.pop("urdf"))
    if not urdf.is_absolute():
        urdf = (path.parent / urdf).resolve()
    return UserRobotConfig(urdf=urdf, source=where, **values)


def _mount(value: object, where: str) -> tuple[float, tuple[float, float] | None]:
    """``(nominal height, range or None)`` of a YAML ``mount_height``: a number, or
    ``[lo, hi]`` (nominal: the middle, to the millimetre)."""
    if isinstance(value, list):
        problem = mount_range_problem(value)
        if problem:
            raise MomaError(f"{where}: field 'mount_height': {problem}")
        lo, hi = float(value[0]), float(value[1])
        return round((lo + hi) / 2, 3), (lo, hi)
    problem = mount_height_problem(value)
    if problem:
        raise MomaError(f"{where}: field 'mount_height' must be a number or [lo, hi]: {problem}")
    assert isinstance(value, int | float)
    return float(value), None


def robot_files_digest(*paths: str | os.PathLike) -> str:
    """sha256 (hex) of a user robot's files' bytes, in order: its YAML, the built-in's YAML
    it is ``like`` (if any), its URDF."""
    digest = hashlib.sha256()
    for path in paths:
        try:
            data = Path(path).read_bytes()
        except OSError as exc:
            raise MomaError(f"cannot read {str(path)!r}: {exc.strerror}") from None
        digest.update(len(data).to_bytes(8, "little"))
        digest.update(data)
    return digest.hexdigest()


def _parent_joints(joints: list[Any], where: str) -> dict[str, Any]:
    """Each child link's joint to its parent, checked to make a tree; MomaError naming a
    link with two parents or one in a loop (the walk to the root would go round forever)."""
    parents: dict[str, Any] = {}
    for joint in joints:
        child = link_of(joint, "child")
        if child in parents:
            raise MomaError(
                f"URDF file {where!r}: link {child!r} has two parents (joints "
                f"{parents[child].get('name')!r} and {joint.get('name')!r}): a URDF must "
                "be a tree, without loops"
            )
        parents[child] = joint
    rooted: set[str] = set()  # links whose walk up ends at a link without a parent
    for start in parents:
        walk: dict[str, None] = {}  # in order, with a fast membership test
        link = start
        while link in parents and link not in rooted:
            if link in walk:
                raise MomaError(
                    f"URDF file {where!r}: link {link!r} is its own ancestor (the joints "
                    "form a loop): a URDF must be a tree"
                )
            walk[link] = None
            link = link_of(parents[link], "parent")
        rooted.update(walk)
    return parents


def _limit(limit: Any, key: str, where: str, joint: Any) -> float:
    """A joint's ``<limit>`` bound (0 when absent, as URDF defines it), checked finite."""
    text = limit.get(key, "0")
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise MomaError(
            f"URDF file {where!r}: joint {joint.get('name')!r} has {key}={text!r}, not a number"
        )
    return value


def _listing(names: list[str], near: str, what: str) -> str:
    """``"its WHAT: [...]"``: up to :data:`_LISTED` of ``names``, those most like ``near``
    (a name that is not among them) first, for an error about ``near``."""
    if not names:
        return f"its {what}: none"
    close = difflib.get_close_matches(near, names, n=_LISTED, cutoff=0.6)
    shown = (close + [n for n in names if n not in close])[:_LISTED]
    more = f" (and {len(names) - len(shown)} more)" if len(names) > len(shown) else ""
    return f"its {what}: {shown}{more}"


def _unique_names(kind: str, names: list[str], reserved: Iterable[str], where: str) -> None:
    """MomaError naming a ``kind`` ("link" or "joint") name of the URDF that is reserved
    (one build_urdf adds) or used twice: PyBullet refuses a URDF with two links of one
    name and crashes on one with two joints of one name."""
    seen: set[str] = set()
    for name in names:
        if name in reserved:
            raise MomaError(f"URDF file {where!r}: {kind} name {name!r} is reserved")
        if name in seen:
            raise MomaError(
                f"URDF file {where!r}: {kind} name {name!r} is used twice; {kind} names "
                "must be unique"
            )
        seen.add(name)


def _finger_problem(
    name: str, joint: Any, chain: set[str], cfg: UserRobotConfig, root: str
) -> str | None:
    """Why URDF joint ``joint`` (named ``name``) cannot be a finger of ``cfg``'s gripper,
    or None: a finger is a prismatic joint off the arm chain (``chain``: the joints from
    the root link ``root`` to the TCP) that closes at 0 and opens to its upper limit."""
    where = str(cfg.urdf)
    kind = joint.get("type")
    if kind != "prismatic":
        return (
            f"finger joint {name!r} is {kind!r} in {where!r}; finger joints must be "
            "prismatic (the fingers slide)"
        )
    if name in chain:
        return (
            f"finger joint {name!r} lies on the arm chain from root link {root!r} to "
            f"end_effector_link {cfg.end_effector_link!r} in {where!r}; fingers must "
            "branch off it (the TCP would move with the finger)"
        )
    limit = joint.find("limit")  # present and finite: checked with every joint's limits
    assert limit is not None
    lower, upper = float(limit.get("lower", "0")), float(limit.get("upper", "0"))
    if not lower <= 0 < upper:
        return (
            f"finger joint {name!r} has limits [{lower:g}, {upper:g}] in {where!r}; a finger "
            "closes at 0 and opens to its upper limit, so needs lower <= 0 < upper"
        )
    return None


def _home_problem(cfg: UserRobotConfig, arm: list[Any]) -> str | None:
    """Why ``cfg.home`` lies outside the URDF limits of its arm joints (``arm``, root to
    TCP; as many as home has values), or None. Continuous joints take any angle."""
    for value, joint in zip(cfg.home, arm, strict=True):
        limit = joint.find("limit")
        if joint.get("type") == "continuous" or limit is None:
            continue
        lower, upper = float(limit.get("lower", "0")), float(limit.get("upper", "0"))
        if not lower - 1e-9 <= value <= upper + 1e-9:
            return (
                f"home value {value:g} for joint {joint.get('name')!r} is outside its limits "
                f"[{lower:g}, {upper:g}] in {str(cfg.urdf)!r}"
            )
    return None


def _model(cfg: UserRobotConfig) -> tuple[RobotModel, int]:
    """Robot model of a user config and its arm DoF; checks the URDF's structure."""
    root = parse_urdf(cfg.urdf)
    where = str(cfg.urdf)
    links = [link.get("name", "") for link in root.findall("link")]
    # A URDF exported from a built robot (robots/export.py) names its TCP frame "tcp":
    # as the end_effector_link it is the TCP itself, and the build adds none above it.
    reserved = (BASE_LINK,) if cfg.end_effector_link == TCP_LINK else (BASE_LINK, TCP_LINK)
    _unique_names("link", links, reserved, where)
    for key in ("end_effector_link", "flange_link"):
        link = getattr(cfg, key)
        if link and link not in links:
            raise MomaError(
                f"URDF file {where!r}: no link {link!r} ({key} in {cfg.source}); "
                + _listing(links, link, "links")
            )
    flange = cfg.flange_link or ("flange" if "flange" in links else cfg.end_effector_link)
    joints = root.findall("joint")
    reserved = RESERVED_JOINTS if cfg.end_effector_link != TCP_LINK else RESERVED_JOINTS[:1]
    _unique_names("joint", [j.get("name", "") for j in joints], reserved, where)
    children = _parent_joints(joints, where)
    roots = [name for name in links if name not in children]
    if len(roots) != 1:
        raise MomaError(f"URDF file {where!r}: expected one root link, found {roots}")
    path, link = [], cfg.end_effector_link
    while link in children:  # ends: the joints form a tree (_parent_joints)
        path.append(children[link])
        link = link_of(children[link], "parent")
    movable = ("revolute", "continuous", "prismatic")
    for j in joints:
        if j.get("type") not in ("revolute", "prismatic"):
            continue
        limit = j.find("limit")
        if limit is None:
            raise MomaError(f"URDF file {where!r}: joint {j.get('name')!r} has no <limit>")
        lower, upper = _limit(limit, "lower", where, j), _limit(limit, "upper", where, j)
        if lower > upper:
            raise MomaError(
                f"URDF file {where!r}: joint {j.get('name')!r} has its limits inverted "
                f"(lower {lower} > upper {upper})"
            )
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
    twice = sorted({f for f in fingers if fingers.count(f) > 1})
    if twice:
        raise MomaError(f"{cfg.source}: finger_joints lists {twice[0]!r} twice")
    by_name = {j.get("name", ""): j for j in joints}
    missing = [f for f in fingers if f not in by_name]
    if missing:
        prismatic = [n for n, j in by_name.items() if j.get("type") == "prismatic"]
        raise MomaError(
            f"{cfg.source}: finger_joints {missing} not in {where!r}; "
            + _listing(prismatic, missing[0], "prismatic joints")
        )
    chain = {j.get("name", "") for j in path}
    for finger in fingers:
        problem = _finger_problem(finger, by_name[finger], chain, cfg, roots[0])
        if problem:
            raise MomaError(f"{cfg.source}: {problem}")
    arm = [j for j in reversed(path) if j.get("type") in movable]
    dof = len(arm)
    if not arm:
        raise MomaError(
            f"{cfg.source}: no movable joint on the chain from root link {roots[0]!r} to "
            f"end_effector_link {cfg.end_effector_link!r} in {where!r}; the TCP must sit "
            "below the arm's joints"
        )
    if cfg.home and len(cfg.home) != dof:
        raise MomaError(f"{cfg.source}: home needs {dof} values (arm joints), got {len(cfg.home)}")
    problem = _home_problem(cfg, arm) if cfg.home else None
    if problem:
        raise MomaError(f"{cfg.source}: {problem}")
    tool = UrdfTool(
        cfg.end_effector,
        cfg.end_effector_link,
        tuple(fingers),
        DEFAULT_FINGER_FORCE if cfg.finger_force is None else cfg.finger_force,
    )
    if cfg.suction_face_tolerance is not None:
        tool = dataclasses.replace(tool, face_tolerance=cfg.suction_face_tolerance)
    model = RobotModel(
        UrdfArm(
            urdf=cfg.urdf,
            root_link=roots[0],
            flange_link=flange,
            mount_yaw=cfg.mount_yaw,
            link_scale=cfg.link_scale,
        ),
        tool,
        home=cfg.home,
        source=f"user robot {cfg.source}",
    )
    return model, dof


def _spec(cfg: UserRobotConfig, model: RobotModel, dof: int, reach: float) -> RobotSpec:
    try:
        return RobotSpec(
            cfg.name,
            reach=reach,
            mount_height=cfg.mount_height,
            mount_range=cfg.mount_range,
            dof=dof,
            end_effector=cfg.end_effector,
            footprint=(cfg.footprint[0], cfg.footprint[1]),
            mount_offset_x=cfg.mount_offset_x,
            model=model,
        )
    except MomaError as exc:
        raise MomaError(f"{cfg.source}: {exc}") from None


def register_shipped(names: Iterable[str]) -> None:
    """Register the built-in robots ``names`` from their files in ``shipped/``: the same
    loader as a user's robot, without the checks a shipped robot passes in the tests (its
    body loaded in PyBullet) and without a user robot's record."""
    for name in names:
        cfg = load_config(shipped_yaml(name))
        if cfg.name != name or cfg.reach is None:
            raise MomaError(f"{cfg.source}: a built-in's YAML needs name {name!r} and a reach")
        model, dof = _model(cfg)
        model = dataclasses.replace(model, source=cfg.provenance)
        register_robot(_spec(cfg, model, dof, cfg.reach))


ROBOTS.load_first(lambda: register_shipped(BUILT_IN_ROBOTS))


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
    like = (shipped_yaml(cfg.like),) if cfg.like else ()
    files = UserRobotFile(cfg.name, key, robot_files_digest(key, *like, cfg.urdf))
    # Registered with a provisional reach when it is to be measured: measuring loads the
    # robot by name.
    spec = register_robot(_spec(cfg, model, dof, cfg.reach if cfg.reach is not None else 1.0))
    try:
        reach = _check_body(cfg, measure_reach=cfg.reach is None)
        if reach is not None:
            spec = register_robot(_spec(cfg, model, dof, round(reach, 3)), replace=True)
    except BaseException:
        ROBOTS.unregister(cfg.name)
        raise
    _LOADED[key] = cfg.name
    _FILES[cfg.name] = files
    return spec


def user_robot_file(name: str) -> UserRobotFile | None:
    """Where registered robot ``name`` comes from (None for a built-in robot)."""
    return _FILES.get(name)


def user_robot_files(names: Iterable[str]) -> tuple[UserRobotFile, ...]:
    """The files of the user robots among ``names`` (built-in ones are left out), in order
    of name, each once."""
    return tuple(_FILES[n] for n in sorted(set(names)) if n in _FILES)


def register_recorded(files: Iterable[UserRobotFile]) -> None:
    """Register user robots recorded elsewhere (a generating process, a dataset), each from
    its YAML path, and check that the files still hash as recorded; MomaError naming the
    file otherwise. Robots already registered from the same files are left as they are.
    Worker processes of generation call this first."""
    for rec in files:
        register_user_robot(rec.yaml)
        problem = recorded_robot_problem(rec)
        if problem:
            raise MomaError(problem)


def recorded_robot_problem(rec: UserRobotFile, what: str = "") -> str | None:
    """Why the registered robots do not hold the user robot of record ``rec`` (not
    registered, or registered from other contents), or None. ``what`` names who recorded
    it, e.g. ``"dataset 'DIR' was labelled with"`` (default: ``"expected"``)."""
    head = f"{what or 'expected'} user robot {rec.name!r} (from {rec.yaml})"
    if rec.name not in ROBOTS:
        return f"{head}; pass --robot-yaml {rec.yaml} (or set {ENV_VAR})"
    now = _FILES.get(rec.name)
    if now is None:
        return f"{head}, but {rec.name!r} is a built-in robot here"
    if now.sha256 != rec.sha256:
        return (
            f"{head}, sha256 {rec.sha256[:12]}, but {rec.name!r} is registered from "
            f"{now.yaml} with sha256 {now.sha256[:12]} (YAML or URDF changed?); pass the "
            "files it was made with"
        )
    return None


def _check_body(cfg: UserRobotConfig, measure_reach: bool) -> float | None:
    """Load the registered robot ``cfg.name`` once: refuse it when its tool reaches
    nothing from the floor (:func:`floor_reach_problem`), and return its measured reach
    (the farthest TCP distance from the shoulder) when ``measure_reach``, else None."""
    from momakitchen.bullet import p
    from momakitchen.robots.reach import measure_workspace
    from momakitchen.robots.robot import Robot

    client = p.connect(p.DIRECT)
    try:
        robot = Robot(client, cfg.name)
        problem = floor_reach_problem(robot, cfg)
        if problem:
            raise MomaError(f"{cfg.source}: {problem}")
        return measure_workspace(robot, 1500)[1] if measure_reach else None
    finally:
        p.disconnect(client)


def floor_reach_problem(robot: RobotBody, cfg: UserRobotConfig, samples: int = 2000) -> str | None:
    """Why the tool of ``robot`` (loaded from ``cfg``, base at the origin) reaches nothing
    from the floor, or None.

    Random joint vectors within the limits (seeded) place the TCP; the tool reaches
    something where some TCP position lies beyond the base's front edge (``footprint[0] /
    2`` from its centre, in any direction: the base turns) at a height of
    :data:`TARGET_HEIGHTS` for some mount height of its range. Reach alone cannot tell: an
    arm whose joints are locked, or whose tool points into the pillar, has a reach but
    moves nothing.
    """
    qs = np.random.default_rng(0).uniform(robot.lower, robot.upper, size=(samples, robot.dof))
    tcp = np.array([robot.tcp_pose(q)[0] for q in qs])
    lo, hi = cfg.mount_range or (cfg.mount_height, cfg.mount_height)
    band_lo, band_hi = TARGET_HEIGHTS
    edge = cfg.footprint[0] / 2
    outside = np.hypot(tcp[:, 0], tcp[:, 1]) > edge
    # the TCP's height with the arm at the lowest and at the highest mount of the range
    low, high = tcp[:, 2] + (lo - cfg.mount_height), tcp[:, 2] + (hi - cfg.mount_height)
    if np.any(outside & (high >= band_lo) & (low <= band_hi)):
        return None
    heights = f"{lo:g} m" if lo == hi else f"{lo:g}-{hi:g} m"
    return (
        f"robot {cfg.name!r}: its tool reaches nothing from the floor: of {samples} sampled "
        f"joint vectors within the limits, none puts {cfg.end_effector_link!r} beyond the "
        f"base's front edge ({edge:g} m from its centre) at a target height ({band_lo:g}-"
        f"{band_hi:g} m) with the arm at a mount height of {heights}"
    )


def robot_yaml_files(path: str | os.PathLike) -> list[Path]:
    """``path`` as robot YAML files: a file itself, a directory its ``*.yaml`` files in
    order of name (MomaError if it holds none)."""
    path = Path(path)
    if not path.is_dir():
        return [path]
    files = sorted(path.glob("*.yaml"))
    if not files:
        raise MomaError(f"robot YAML directory {str(path)!r} holds no *.yaml file")
    return files


def register_user_robots(path: str | os.PathLike) -> list[RobotSpec]:
    """Register the robot of YAML file ``path``, or of every YAML file of directory
    ``path`` (:func:`robot_yaml_files`)."""
    return [register_user_robot(f) for f in robot_yaml_files(path)]


def load_env_robots() -> list[RobotSpec]:
    """Register the robots listed in ``$MOMAKITCHEN_ROBOT_YAML`` (os.pathsep-separated
    files or directories)."""
    paths = [s for s in os.environ.get(ENV_VAR, "").split(os.pathsep) if s.strip()]
    return [spec for path in paths for spec in register_user_robots(path)]


def unregister_user_robot(name: str) -> None:
    """Remove a user robot from the registries (built-in robots cannot be removed)."""
    from momakitchen.robots.robot import forget_caches

    if name not in _LOADED.values():
        raise MomaError(f"{name!r} is not a registered user robot")
    for key in [k for k, v in _LOADED.items() if v == name]:
        del _LOADED[key]
    _FILES.pop(name, None)
    ROBOTS.unregister(name)
    forget_caches(name)
