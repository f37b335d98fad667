"""Where an arm's shoulder stands on its base, from the robot's URDF alone (no simulator).

Two arms of one reach and mount height can still stand their shoulders 11 cm apart in
height (the Elephant's at 0.23 m above its mount, a Realman scaled to the Elephant's reach
at 0.12 m), and that decides how far from a low door or a counter the base must stop
(docs/ROBOTS.md "Where the shoulder stands"). The robot descriptor (version 3) carries it.

The figures are those of :class:`~momakitchen.robots.body.ReachGeometry` (measured there in
PyBullet from link frames): the shoulder is the origin of the second movable joint of the
chain from the base to the TCP, projected on the first joint's axis.
"""

from __future__ import annotations

import functools
import math
import xml.etree.ElementTree as ET

import numpy as np

from momakitchen.errors import MomaError
from momakitchen.robots.spec import RobotSpec
from momakitchen.robots.urdf import BASE_LINK, TCP_LINK, build_urdf, link_of


def _floats(text: str | None, default: tuple[float, float, float]) -> np.ndarray:
    return np.array(default if text is None else [float(v) for v in text.split()], float)


def _origin(joint: ET.Element) -> np.ndarray:
    """The joint's ``<origin>`` as a 4x4 transform (parent link -> joint frame)."""
    node = joint.find("origin")
    xyz = _floats(None if node is None else node.get("xyz"), (0.0, 0.0, 0.0))
    r, p, y = _floats(None if node is None else node.get("rpy"), (0.0, 0.0, 0.0))
    # URDF's rpy: fixed axes x, then y, then z (R = Rz(y) Ry(p) Rx(r)).
    cr, sr = math.cos(r), math.sin(r)
    cp, sp = math.cos(p), math.sin(p)
    cy, sy = math.cos(y), math.sin(y)
    t = np.eye(4)
    t[:3, :3] = [
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ]
    t[:3, 3] = xyz
    return t


def _shoulder_from_urdf(urdf: str) -> tuple[float, float]:
    """``(height, offset)`` of the shoulder at the arm's zero configuration, metres: its
    projection on the first joint's axis above the floor, and its distance from that axis."""
    root = ET.fromstring(urdf)
    by_child = {link_of(j, "child"): j for j in root.findall("joint")}
    chain, link = [], TCP_LINK
    while link != BASE_LINK:
        joint = by_child.get(link)
        if joint is None:
            raise MomaError(f"robot URDF: no joint chain from {TCP_LINK!r} to {BASE_LINK!r}")
        chain.append(joint)
        link = link_of(joint, "parent")
    frames, t = [], np.eye(4)
    for joint in reversed(chain):
        t = t @ _origin(joint)
        if joint.get("type") != "fixed":
            node = joint.find("axis")  # URDF's default axis is x
            frames.append((t.copy(), _floats(None if node is None else node.get("xyz"), (1, 0, 0))))
    if len(frames) < 2:
        raise MomaError("robot URDF: the arm needs at least two movable joints")
    (first, axis_local), (second, _) = frames[0], frames[1]
    axis = first[:3, :3] @ axis_local
    axis /= np.linalg.norm(axis)
    shoulder = second[:3, 3]
    centre = first[:3, 3] + float((shoulder - first[:3, 3]) @ axis) * axis
    return float(centre[2]), float(np.linalg.norm(shoulder - centre))


@functools.lru_cache(maxsize=512)
def shoulder_geometry(spec: RobotSpec) -> tuple[float, float]:
    """``(rise, offset)`` of the robot's shoulder, metres: its height above the arm's mount
    (the same at every mount height) and its distance from the first joint's axis."""
    z, offset = _shoulder_from_urdf(build_urdf(spec))
    return z - spec.mount_height, offset
