"""Rest poses of URDF links, computed from the joint origins alone (pure Python).

The layout sampler needs to know where a handle is before any simulator exists, e.g. to
centre a sampling semicircle on it. With every joint at position 0, a link's pose in the
root-link frame is the product of the joint origins along its chain.
"""

from __future__ import annotations

import functools
import xml.etree.ElementTree as ET

import numpy as np

from momakitchen.errors import MomaError
from momakitchen.frames import rpy_matrix


def _required_child(elem: ET.Element, tag: str, what: str) -> ET.Element:
    child = elem.find(tag)
    if child is None:
        raise MomaError(f"malformed URDF: {what} has no <{tag}> element")
    return child


def _required_attr(elem: ET.Element, attr: str, what: str) -> str:
    value = elem.get(attr)
    if value is None:
        raise MomaError(f"malformed URDF: {what} has no {attr!r} attribute")
    return value


def _origin(elem: ET.Element | None) -> np.ndarray:
    tf = np.eye(4)
    if elem is None:
        return tf
    xyz = [float(v) for v in elem.get("xyz", "0 0 0").split()]
    rpy = [float(v) for v in elem.get("rpy", "0 0 0").split()]
    tf[:3, :3] = rpy_matrix(*rpy)
    tf[:3, 3] = xyz
    return tf


@functools.lru_cache(maxsize=256)
def _parse(urdf: str) -> ET.Element:
    """The URDF's XML tree, parsed once per text (cached: do not modify it)."""
    try:
        return ET.fromstring(urdf)
    except ET.ParseError as exc:
        raise MomaError(f"URDF does not parse: {exc}") from None


@functools.lru_cache(maxsize=256)
def link_rest_poses(urdf: str) -> dict[str, np.ndarray]:
    """Pose of every link in the root-link frame with all joints at 0 (cached: do not
    modify the returned arrays).

    Returns:
        Mapping link name -> homogeneous transform of shape (4, 4).
    """
    root = _parse(urdf)
    links = [_required_attr(link, "name", "<link>") for link in root.findall("link")]
    parent_of: dict[str, tuple[str, np.ndarray]] = {}
    for joint in root.findall("joint"):
        what = f"<joint name={joint.get('name')!r}>"
        child = _required_attr(_required_child(joint, "child", what), "link", f"{what} <child>")
        parent = _required_attr(_required_child(joint, "parent", what), "link", f"{what} <parent>")
        parent_of[child] = (parent, _origin(joint.find("origin")))
    poses: dict[str, np.ndarray] = {}

    def pose(name: str) -> np.ndarray:
        if name not in poses:
            if name in parent_of:
                parent, tf = parent_of[name]
                poses[name] = pose(parent) @ tf
            else:
                poses[name] = np.eye(4)
        return poses[name]

    for name in links:
        pose(name)
    return poses


@functools.lru_cache(maxsize=256)
def joint_axes(urdf: str) -> dict[str, tuple[str, np.ndarray]]:
    """Every joint's child link and axis, the axis in that child link's frame (URDF's
    default (1, 0, 0) where none is given; do not modify the returned arrays)."""
    root = _parse(urdf)
    out = {}
    for joint in root.findall("joint"):
        what = f"<joint name={joint.get('name')!r}>"
        name = _required_attr(joint, "name", "<joint>")
        child = _required_attr(_required_child(joint, "child", what), "link", f"{what} <child>")
        axis = joint.find("axis")
        xyz = axis.get("xyz", "1 0 0") if axis is not None else "1 0 0"
        out[name] = (child, np.array([float(v) for v in xyz.split()]))
    return out


@functools.lru_cache(maxsize=256)
def link_extent_points(urdf: str, link: str) -> np.ndarray:
    """Corners of the boxes bounding each collision shape of ``link``, in that link's
    frame (do not modify the returned array). Shape (8 * shapes, 3); (0, 3) for a link
    without collision shapes."""
    root = _parse(urdf)
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    points = [np.zeros((0, 3))]
    for elem in root.findall("link"):
        if elem.get("name") != link:
            continue
        for collision in elem.findall("collision"):
            geometry = _required_child(collision, "geometry", f"<link name={link!r}> <collision>")
            if (box := geometry.find("box")) is not None:
                half = np.array([float(v) for v in box.get("size", "0 0 0").split()]) / 2
            elif (cyl := geometry.find("cylinder")) is not None:
                r, length = float(cyl.get("radius", 0)), float(cyl.get("length", 0))
                half = np.array([r, r, length / 2])
            elif (sphere := geometry.find("sphere")) is not None:
                half = np.full(3, float(sphere.get("radius", 0)))
            else:  # meshes: not used by the procedural assets
                continue
            tf = _origin(collision.find("origin"))
            points.append((signs * half) @ tf[:3, :3].T + tf[:3, 3])
    return np.concatenate(points)
