"""Small helpers that emit URDF XML from primitive shapes.

Categories describe an asset as :class:`Link` s made of :class:`Shape` s (box, cylinder,
sphere) and :class:`Joint` s; :func:`robot_urdf` writes the XML. Mass properties are computed
here (mass split over the collision shapes by volume, parallel-axis theorem, rotated inertia
tensors), so every category gets correct inertias without repeating the formulas.

Floats are written by :func:`fmt` (fixed precision, no ``-0``), so the same parameters always
give byte-identical text, which is what the content-hash cache relies on.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from xml.sax.saxutils import quoteattr

import numpy as np

from momakitchen.errors import MomaError
from momakitchen.frames import rpy_matrix

Vec3 = tuple[float, float, float]
RGBA = tuple[float, float, float, float]

ZERO: Vec3 = (0.0, 0.0, 0.0)
# A cylinder's axis is its local z; these rotations lay it along x or y.
ALONG_X: Vec3 = (0.0, math.pi / 2, 0.0)
ALONG_Y: Vec3 = (math.pi / 2, 0.0, 0.0)


@functools.lru_cache(maxsize=1 << 16)
def fmt(x: float) -> str:
    """Deterministic float text: 6 decimals, trailing zeros stripped, never ``-0``."""
    s = f"{float(x):.6f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "", "-") else s


def _vec(v: tuple[float, ...]) -> str:
    return " ".join(fmt(x) for x in v)


@dataclass(frozen=True)
class Box:
    size: Vec3


@dataclass(frozen=True)
class Cylinder:
    """Solid cylinder, axis along the shape's local z."""

    radius: float
    length: float


@dataclass(frozen=True)
class Sphere:
    radius: float


Geometry = Box | Cylinder | Sphere


@dataclass(frozen=True)
class Shape:
    """A primitive placed in its link frame. ``material`` names an entry of the robot's
    material table. Visual-only shapes (``collision=False``) carry no mass."""

    geometry: Geometry
    xyz: Vec3 = ZERO
    rpy: Vec3 = ZERO
    material: str = "default"
    collision: bool = True
    visual: bool = True
    density: float = 1.0  # relative weight when a link's mass is split over its shapes


@dataclass(frozen=True)
class Contact:
    """PyBullet ``<contact>`` coefficients of a link (read by ``loadURDF``)."""

    lateral_friction: float = 0.8
    rolling_friction: float = 0.0
    spinning_friction: float = 0.0
    restitution: float = 0.0


@dataclass(frozen=True)
class Link:
    name: str
    shapes: tuple[Shape, ...]
    mass: float
    contact: Contact | None = None


@dataclass(frozen=True)
class Joint:
    """A URDF joint. Limits are in rad (revolute) or m (prismatic)."""

    name: str
    type: str  # fixed | revolute | prismatic
    parent: str
    child: str
    xyz: Vec3 = ZERO
    rpy: Vec3 = ZERO
    axis: Vec3 = (0.0, 0.0, 1.0)
    lower: float = 0.0
    upper: float = 0.0
    effort: float = 100.0
    velocity: float = 3.0
    damping: float = 0.0
    friction: float = 0.0


# ---------------------------------------------------------------- geometry and mass


_IDENTITY = np.eye(3)
_IDENTITY.flags.writeable = False


def rot(rpy: Vec3) -> np.ndarray:
    """URDF rotation matrix of fixed-axis roll, pitch, yaw: R = Rz(y) Ry(p) Rx(r)."""
    if not any(rpy):
        return _IDENTITY  # most shapes are axis-aligned
    return rpy_matrix(*rpy)


def volume(g: Geometry) -> float:
    if isinstance(g, Box):
        return g.size[0] * g.size[1] * g.size[2]
    if isinstance(g, Cylinder):
        return math.pi * g.radius**2 * g.length
    return 4.0 / 3.0 * math.pi * g.radius**3


def _local_inertia(g: Geometry, m: float) -> np.ndarray:
    """Inertia tensor of a solid primitive of mass ``m`` about its centre, in its own frame."""
    if isinstance(g, Box):
        a, b, c = g.size
        return np.diag([m * (b * b + c * c), m * (a * a + c * c), m * (a * a + b * b)]) / 12.0
    if isinstance(g, Cylinder):
        r, h = g.radius, g.length
        ixx = m * (3 * r * r + h * h) / 12.0
        return np.diag([ixx, ixx, m * r * r / 2.0])
    return np.eye(3) * (0.4 * m * g.radius**2)


def density_mass(shapes: tuple[Shape, ...] | list[Shape]) -> float:
    """Mass (kg) of the collision shapes when ``density`` is in kg/m^3."""
    return float(sum(volume(s.geometry) * s.density for s in shapes if s.collision))


def mass_properties(link: Link) -> tuple[np.ndarray, np.ndarray]:
    """Centre of mass and inertia tensor about it (link frame), with the link mass split over
    its collision shapes in proportion to their volume (uniform density)."""
    shapes = [s for s in link.shapes if s.collision] or list(link.shapes)
    vols = np.array([volume(s.geometry) * s.density for s in shapes])
    if link.mass <= 0 or vols.sum() <= 0:
        raise MomaError(f"link {link.name!r}: mass and shape volume must be positive")
    masses = link.mass * vols / vols.sum()
    com = sum(m * np.asarray(s.xyz) for m, s in zip(masses, shapes, strict=True)) / link.mass
    inertia = np.zeros((3, 3))
    for m, s in zip(masses, shapes, strict=True):
        r = rot(s.rpy)
        d = np.asarray(s.xyz) - com
        inertia += r @ _local_inertia(s.geometry, m) @ r.T
        inertia += m * (np.dot(d, d) * np.eye(3) - np.outer(d, d))
    return com, inertia


def link_poses(links: tuple[Link, ...], joints: tuple[Joint, ...]) -> dict[str, tuple]:
    """World pose (R, p) of every link frame with all joints at position 0."""
    root = {lk.name for lk in links} - {j.child for j in joints}
    if len(root) != 1:
        raise MomaError(f"URDF must have exactly one root link, found {sorted(root)}")
    poses = {root.pop(): (np.eye(3), np.zeros(3))}
    pending = list(joints)
    while pending:
        progress = False
        for j in list(pending):
            if j.parent in poses:
                rp, pp = poses[j.parent]
                poses[j.child] = (rp @ rot(j.rpy), pp + rp @ np.asarray(j.xyz))
                pending.remove(j)
                progress = True
        if not progress:
            raise MomaError(f"joints {[j.name for j in pending]} do not connect to the root link")
    return poses


def bounding_box(links: tuple[Link, ...], joints: tuple[Joint, ...]) -> tuple[Vec3, Vec3]:
    """(lower, upper) corners of the collision geometry in the root frame, joints at 0."""
    poses = link_poses(links, joints)
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    for lk in links:
        r, p = poses[lk.name]
        for s in lk.shapes:
            if not s.collision:
                continue
            c = p + r @ np.asarray(s.xyz)
            # compose the shape rotation with the link rotation for the extents
            rr = r @ rot(s.rpy)
            he = _half_extents_matrix(s.geometry, rr)
            lo = np.minimum(lo, c - he)
            hi = np.maximum(hi, c + he)
    return tuple(lo.tolist()), tuple(hi.tolist())


def _half_extents_matrix(g: Geometry, r: np.ndarray) -> np.ndarray:
    if isinstance(g, Box):
        return np.abs(r) @ (np.asarray(g.size) / 2.0)
    if isinstance(g, Cylinder):
        a = r[:, 2]
        return g.radius * np.sqrt(np.clip(1.0 - a * a, 0.0, 1.0)) + g.length / 2.0 * np.abs(a)
    return np.full(3, g.radius)


# ---------------------------------------------------------------- XML


def _geometry_xml(g: Geometry) -> str:
    if isinstance(g, Box):
        return f'<box size="{_vec(g.size)}"/>'
    if isinstance(g, Cylinder):
        return f'<cylinder radius="{fmt(g.radius)}" length="{fmt(g.length)}"/>'
    return f'<sphere radius="{fmt(g.radius)}"/>'


def _origin(xyz: Vec3, rpy: Vec3) -> str:
    return f'<origin xyz="{_vec(xyz)}" rpy="{_vec(rpy)}"/>'


def _link_xml(link: Link, materials: dict[str, RGBA]) -> list[str]:
    com, inertia = mass_properties(link)
    out = [f"  <link name={quoteattr(link.name)}>"]
    if link.contact is not None:
        c = link.contact
        out += [
            "    <contact>",
            f'      <lateral_friction value="{fmt(c.lateral_friction)}"/>',
            f'      <rolling_friction value="{fmt(c.rolling_friction)}"/>',
            f'      <spinning_friction value="{fmt(c.spinning_friction)}"/>',
            f'      <restitution value="{fmt(c.restitution)}"/>',
            "    </contact>",
        ]
    i = inertia
    out += [
        "    <inertial>",
        f"      {_origin(tuple(com.tolist()), ZERO)}",
        f'      <mass value="{fmt(link.mass)}"/>',
        f'      <inertia ixx="{fmt(i[0, 0])}" ixy="{fmt(i[0, 1])}" ixz="{fmt(i[0, 2])}"'
        f' iyy="{fmt(i[1, 1])}" iyz="{fmt(i[1, 2])}" izz="{fmt(i[2, 2])}"/>',
        "    </inertial>",
    ]
    for s in link.shapes:
        geom = _geometry_xml(s.geometry)
        if s.visual:
            if s.material not in materials:
                raise MomaError(f"link {link.name!r}: unknown material {s.material!r}")
            out += [
                "    <visual>",
                f"      {_origin(s.xyz, s.rpy)}",
                f"      <geometry>{geom}</geometry>",
                f"      <material name={quoteattr(s.material)}>"
                f'<color rgba="{_vec(materials[s.material])}"/></material>',
                "    </visual>",
            ]
        if s.collision:
            out += [
                "    <collision>",
                f"      {_origin(s.xyz, s.rpy)}",
                f"      <geometry>{geom}</geometry>",
                "    </collision>",
            ]
    out.append("  </link>")
    return out


def _joint_xml(j: Joint) -> list[str]:
    out = [
        f"  <joint name={quoteattr(j.name)} type={quoteattr(j.type)}>",
        f"    <parent link={quoteattr(j.parent)}/>",
        f"    <child link={quoteattr(j.child)}/>",
        f"    {_origin(j.xyz, j.rpy)}",
    ]
    if j.type != "fixed":
        out += [
            f'    <axis xyz="{_vec(j.axis)}"/>',
            f'    <limit lower="{fmt(j.lower)}" upper="{fmt(j.upper)}"'
            f' effort="{fmt(j.effort)}" velocity="{fmt(j.velocity)}"/>',
            f'    <dynamics damping="{fmt(j.damping)}" friction="{fmt(j.friction)}"/>',
        ]
    out.append("  </joint>")
    return out


def robot_urdf(
    name: str,
    links: tuple[Link, ...],
    joints: tuple[Joint, ...] = (),
    materials: dict[str, RGBA] | None = None,
) -> str:
    """URDF text of a robot (asset). Links and joints are written in the order given."""
    materials = dict(materials or {})
    materials.setdefault("default", (0.7, 0.7, 0.7, 1.0))
    link_poses(links, joints)  # validates the tree
    names = [lk.name for lk in links]
    if len(set(names)) != len(names):
        raise MomaError(f"URDF {name!r}: duplicate link names")
    lines = ['<?xml version="1.0"?>', f"<robot name={quoteattr(name)}>"]
    for lk in links:
        lines += _link_xml(lk, materials)
    for j in joints:
        lines += _joint_xml(j)
    lines.append("</robot>")
    return "\n".join(lines) + "\n"


def rgba(c: tuple[float, ...], alpha: float = 1.0) -> RGBA:
    """An RGBA tuple from an RGB(A) tuple, components rounded to 1e-3 (stable text)."""
    r, g, b = (round(float(min(max(x, 0.0), 1.0)), 3) for x in c[:3])
    a = round(float(c[3]), 3) if len(c) > 3 else alpha
    return (r, g, b, a)
