"""One URDF per robot: the mobile base with the robot's own arm and tool on it.

The base is a box footprint with a pillar up to the mount height; the arm and tool come from
the robot's URDF file (``user.py``; the built-ins' are in ``shipped/``) and are attached to
the top of the pillar with a fixed joint, re-emitted with absolute mesh paths, so the file
loads anywhere with plain ``p.loadURDF(path)``.

Link names the rest of the package relies on: ``mobile_base`` (root, footprint and
pillar) and ``tcp`` (tool centre point: z = approach, fingers close along y).
"""

from __future__ import annotations

import dataclasses
import math
import xml.etree.ElementTree as ET
from pathlib import Path

from momakitchen.errors import MomaError
from momakitchen.fileio import existing_file
from momakitchen.robots.arms import PYBULLET_DATA
from momakitchen.robots.scaled import scale_arm
from momakitchen.robots.spec import (
    RobotSpec,
    get_robot_spec,
    mount_height_problem,
)

BASE_LINK = "mobile_base"
TCP_LINK = "tcp"

BASE_CLEARANCE = 0.03  # ground clearance of the base box (wheels are below it)
BASE_BOX_TOP = 0.33  # top of the base box; a pillar continues up to the mount height
PILLAR_RADIUS = 0.08

_MATERIALS = {
    "mk_base": "0.25 0.27 0.30 1",
    "mk_pillar": "0.55 0.57 0.60 1",
    "mk_arm": "0.85 0.86 0.88 1",
    "mk_joint": "0.20 0.35 0.65 1",
    "mk_tool": "0.15 0.15 0.15 1",
}


def _fmt(values) -> str:
    return " ".join(f"{float(v):.9g}" for v in values)


def _origin(parent: ET.Element, xyz=(0, 0, 0), rpy=(0, 0, 0)) -> None:
    ET.SubElement(parent, "origin", xyz=_fmt(xyz), rpy=_fmt(rpy))


def _geometry(parent: ET.Element, kind: str, **attrs) -> None:
    geom = ET.SubElement(parent, "geometry")
    values = {
        k: (_fmt(v) if isinstance(v, tuple) else f"{v:.9g}" if isinstance(v, float) else str(v))
        for k, v in attrs.items()
    }
    ET.SubElement(geom, kind, values)


def _shape(
    link: ET.Element, kind: str, xyz, rpy, material: str | None, *, collide: bool = True, **attrs
) -> None:
    """Add the same primitive as visual (with ``material``) and, if ``collide``, collision."""
    vis = ET.SubElement(link, "visual")
    _origin(vis, xyz, rpy)
    _geometry(vis, kind, **attrs)
    if material:
        ET.SubElement(vis, "material", name=material)
    if collide:
        col = ET.SubElement(link, "collision")
        _origin(col, xyz, rpy)
        _geometry(col, kind, **attrs)


def _inertial(link: ET.Element, mass: float, com=(0, 0, 0), inertia: float | None = None) -> None:
    inert = ET.SubElement(link, "inertial")
    _origin(inert, com)
    ET.SubElement(inert, "mass", value=f"{mass:.6g}")
    i = inertia if inertia is not None else max(1e-6, 0.002 * mass)
    ET.SubElement(
        inert, "inertia", ixx=f"{i:.6g}", iyy=f"{i:.6g}", izz=f"{i:.6g}", ixy="0", ixz="0", iyz="0"
    )


def _joint(
    robot: ET.Element,
    name: str,
    kind: str,
    parent: str,
    child: str,
    xyz=(0, 0, 0),
    rpy=(0, 0, 0),
    axis=None,
    limit=None,
) -> ET.Element:
    joint = ET.SubElement(robot, "joint", name=name, type=kind)
    ET.SubElement(joint, "parent", link=parent)
    ET.SubElement(joint, "child", link=child)
    _origin(joint, xyz, rpy)
    if axis is not None:
        ET.SubElement(joint, "axis", xyz=_fmt(axis))
    if limit is not None:
        lower, upper, effort, velocity = limit
        ET.SubElement(
            joint,
            "limit",
            lower=f"{lower:.9g}",
            upper=f"{upper:.9g}",
            effort=f"{effort:.6g}",
            velocity=f"{velocity:.6g}",
        )
    return joint


# --------------------------------------------------------------------------------------
# Mobile base


def _base(robot: ET.Element, spec: RobotSpec) -> None:
    """Root link: box footprint, pillar up to the mount height, wheels (visual only)."""
    length, width = spec.footprint
    top = min(BASE_BOX_TOP, spec.mount_height)
    bottom = min(BASE_CLEARANCE, top / 2)
    link = ET.SubElement(robot, "link", name=BASE_LINK)
    # Inertial frame at the link frame: PyBullet places a base by its centre of mass.
    _inertial(link, 40.0, (0, 0, 0), inertia=1.0)
    _shape(
        link,
        "box",
        (0, 0, (top + bottom) / 2),
        (0, 0, 0),
        "mk_base",
        size=(length, width, top - bottom),
    )
    pillar = spec.mount_height - top
    if pillar > 0.005:
        _shape(
            link,
            "cylinder",
            (spec.mount_offset_x, 0, top + pillar / 2),
            (0, 0, 0),
            "mk_pillar",
            radius=PILLAR_RADIUS,
            length=pillar,
        )
    for sx in (-1, 1):
        for sy in (-1, 1):
            _shape(
                link,
                "cylinder",
                (sx * length * 0.32, sy * (width / 2 - 0.03), 0.05),
                (math.pi / 2, 0, 0),
                "mk_tool",
                collide=False,
                radius=0.05,
                length=0.04,
            )


# --------------------------------------------------------------------------------------
# The arm and tool, from the robot's URDF


def _resolve_mesh(filename: str, urdf_dir: Path) -> str:
    """Absolute path of a mesh referenced from a URDF in ``urdf_dir``.

    ``package://pkg/rest`` is looked up as ``rest`` or ``pkg/rest`` under the URDF's folder
    and its ancestors (how ROS description packages sit next to their URDFs);
    ``package://pybullet_data/rest`` in the installed ``pybullet_data`` (the built-in Panda
    and xArm6 use its meshes).
    """
    if filename.startswith("package://pybullet_data/"):
        candidates = [str(PYBULLET_DATA / filename[len("package://pybullet_data/") :])]
    elif filename.startswith("package://"):
        rest = filename[len("package://") :]
        candidates = [rest, rest.split("/", 1)[1] if "/" in rest else rest]
    elif filename.startswith("file://"):
        candidates = [filename[len("file://") :]]
    else:
        candidates = [filename]
    for cand in candidates:
        if Path(cand).is_absolute() and Path(cand).exists():
            return cand
        for base in (urdf_dir, *list(urdf_dir.parents)[:3]):
            path = base / cand
            if path.exists():
                return str(path.resolve())
    raise MomaError(f"mesh {filename!r} referenced by a URDF in {str(urdf_dir)!r} not found")


def link_of(joint: ET.Element, end: str) -> str:
    """The link named by a joint's ``<parent>`` or ``<child>`` (``end``); MomaError if the
    joint does not name one."""
    node = joint.find(end)
    link = None if node is None else node.get("link")
    if link is None:
        raise MomaError(f"URDF joint {joint.get('name')!r} has no <{end} link=...>")
    return link


def parse_urdf(path: Path) -> ET.Element:
    """Parse a URDF file; MomaError naming the file on a missing file or malformed XML."""
    path = existing_file(path, "URDF file")
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError) as exc:
        raise MomaError(f"URDF file {str(path)!r} does not parse: {exc}") from None
    if root.tag != "robot":
        raise MomaError(f"URDF file {str(path)!r}: root element must be <robot>, got <{root.tag}>")
    names = [link.get("name") for link in root.findall("link")]
    if not names or any(not n for n in names):
        raise MomaError(f"URDF file {str(path)!r}: needs named <link> elements")
    for joint in root.findall("joint"):
        for tag in ("parent", "child"):
            el = joint.find(tag)
            if el is None or el.get("link") not in names:
                raise MomaError(
                    f"URDF file {str(path)!r}: joint {joint.get('name')!r} has a missing or "
                    f"unknown {tag} link"
                )
    return root


def subtree(root: ET.Element, start: str) -> set[str]:
    """The names of link ``start`` and of every link below it in URDF ``root``."""
    children: dict[str, list[str]] = {}
    for joint in root.findall("joint"):
        children.setdefault(link_of(joint, "parent"), []).append(link_of(joint, "child"))
    keep, stack = set(), [start]
    while stack:
        name = stack.pop()
        keep.add(name)
        stack.extend(children.get(name, []))
    return keep


def embed_urdf(
    robot: ET.Element,
    src: ET.Element,
    urdf_dir: Path,
    root_link: str,
    mount_parent: str,
    mount_xyz,
    mount_yaw: float = 0.0,
) -> None:
    """Copy the links and joints of ``src`` under ``root_link`` into ``robot``.

    Mesh paths become absolute, ``<mimic>`` tags are dropped (PyBullet ignores them; the
    fingers are driven one by one), and ``root_link`` is attached to ``mount_parent`` with a
    fixed joint, turned ``mount_yaw`` radians about the vertical.
    """
    names = {link.get("name") for link in src.findall("link")}
    if root_link not in names:
        raise MomaError(f"URDF has no link {root_link!r}")
    keep = subtree(src, root_link)
    taken = {el.get("name") for el in robot.findall("link")}
    clash = keep & taken
    if clash:
        raise MomaError(f"URDF link names clash with the mobile base: {sorted(clash)}")
    # A material the base already defines (the built-ins' URDFs carry them) is not
    # defined twice.
    materials = {mat.get("name") for mat in robot.findall("material")}
    for mat in src.findall("material"):
        if mat.get("name") not in materials:
            robot.append(mat)
    for link in src.findall("link"):
        if link.get("name") not in keep:
            continue
        # Massless links (frames such as panda_link8) upset PyBullet's Jacobian.
        for mass in link.iter("mass"):
            if float(mass.get("value", "0")) <= 0.0:
                mass.set("value", "0.001")
        for mesh in link.iter("mesh"):
            mesh.set("filename", _resolve_mesh(mesh.get("filename", ""), urdf_dir))
        robot.append(link)
    for joint in src.findall("joint"):
        if link_of(joint, "parent") not in keep or link_of(joint, "child") not in keep:
            continue
        for mimic in joint.findall("mimic"):
            joint.remove(mimic)
        robot.append(joint)
    _joint(robot, "mount_joint", "fixed", mount_parent, root_link, mount_xyz, (0, 0, mount_yaw))


# --------------------------------------------------------------------------------------
# The whole robot


def mounted(spec: RobotSpec, mount_height: float | None) -> RobotSpec:
    """``spec`` with its arm at ``mount_height`` (None or its own height: ``spec`` itself);
    MomaError naming the value if it lies outside :data:`~momakitchen.robots.spec.MOUNT_RANGE`
    (any arm may stand at any height of it, whatever range it samples from by default)."""
    if mount_height is None or mount_height == spec.mount_height:
        return spec
    problem = mount_height_problem(mount_height)
    if problem:
        raise MomaError(f"robot {spec.name!r}: {problem}")
    return dataclasses.replace(spec, mount_height=float(mount_height), mount_range=None)


def build_urdf(spec: RobotSpec, mount_height: float | None = None) -> str:
    """URDF text of the whole robot (base + the arm and tool of ``spec.model``), the arm at
    ``mount_height`` (default: the robot's own); deterministic. The mount height only sets
    the pillar's length and the arm's mount joint: the arm and tool are the same."""
    spec = mounted(spec, mount_height)
    model = spec.model
    robot = ET.Element("robot", name=f"momakitchen_{spec.name}")
    for name, rgba in _MATERIALS.items():
        mat = ET.SubElement(robot, "material", name=name)
        ET.SubElement(mat, "color", rgba=rgba)
    _base(robot, spec)
    mount = (spec.mount_offset_x, 0.0, spec.mount_height)
    arm, tool = model.arm, model.end_effector
    src = parse_urdf(arm.urdf)
    if arm.link_scale != 1.0:
        scale_arm(src, subtree(src, arm.flange_link) - {arm.flange_link}, arm.link_scale)
    embed_urdf(robot, src, arm.urdf.parent, arm.root_link, BASE_LINK, mount, arm.mount_yaw)
    # The TCP frame is named uniformly; a URDF whose TCP link is already named so (the
    # built-ins', one exported by robots/export.py) gets no extra frame.
    if tool.tcp_link != TCP_LINK:
        link = ET.SubElement(robot, "link", name=TCP_LINK)
        _inertial(link, 0.001, inertia=1e-6)
        _joint(robot, "tcp_joint", "fixed", tool.tcp_link, TCP_LINK)
    ET.indent(robot)
    return '<?xml version="1.0"?>\n' + ET.tostring(robot, encoding="unicode") + "\n"


def robot_urdf(name: str, mount_height: float | None = None) -> str:
    """URDF text of a registered robot (its arm at ``mount_height``; default its own)."""
    return build_urdf(get_robot_spec(name), mount_height)


def robot_urdf_path(name: str, mount_height: float | None = None) -> Path:
    """Path of the cached URDF file of a registered robot, its arm at ``mount_height``
    (default its own; written on first use)."""
    from momakitchen.assets.cache import cached_urdf

    return cached_urdf(robot_urdf(name, mount_height), f"robot-{name}")
