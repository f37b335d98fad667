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
import xml.etree.ElementTree as ET

import numpy as np

from momakitchen.assets.urdf_frames import joint_axes, link_rest_poses
from momakitchen.errors import MomaError
from momakitchen.robots.spec import RobotSpec
from momakitchen.robots.urdf import BASE_LINK, TCP_LINK, build_urdf, link_of


def _shoulder_from_urdf(urdf: str) -> tuple[float, float]:
    """``(height, offset)`` of the shoulder at the arm's zero configuration, metres: its
    projection on the first joint's axis above the floor, and its distance from that axis."""
    by_child = {link_of(j, "child"): j for j in ET.fromstring(urdf).findall("joint")}
    movable, link = [], TCP_LINK  # (joint, child link) of the movable joints, TCP first
    while link != BASE_LINK:
        joint = by_child.get(link)
        if joint is None:
            raise MomaError(f"robot URDF: no joint chain from {TCP_LINK!r} to {BASE_LINK!r}")
        if joint.get("type") != "fixed":
            movable.append((joint.get("name", ""), link))
        link = link_of(joint, "parent")
    if len(movable) < 2:
        raise MomaError("robot URDF: the arm needs at least two movable joints")
    (name, first_link), (_, second_link) = movable[-1], movable[-2]
    # A joint's frame is its child link's frame; the base link is the URDF's root.
    poses = link_rest_poses(urdf)
    first = poses[first_link]
    axis = first[:3, :3] @ joint_axes(urdf)[name][1]
    axis /= np.linalg.norm(axis)
    shoulder = poses[second_link][:3, 3]
    centre = first[:3, 3] + float((shoulder - first[:3, 3]) @ axis) * axis
    return float(centre[2]), float(np.linalg.norm(shoulder - centre))


@functools.lru_cache(maxsize=512)
def shoulder_geometry(spec: RobotSpec) -> tuple[float, float]:
    """``(rise, offset)`` of the robot's shoulder, metres: its height above the arm's mount
    (the same at every mount height) and its distance from the first joint's axis."""
    z, offset = _shoulder_from_urdf(build_urdf(spec))
    return z - spec.mount_height, offset
