"""Collisions of a :class:`~momakitchen.robots.robot.Robot` with the scene and itself.

``Robot.base_collisions`` and ``Robot.arm_collisions`` call these functions. The
self-collision pairs (like an SRDF's enabled pairs) are computed once per robot, mount
height and process (:data:`SELF_PAIRS_CACHE`).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from momakitchen.bullet import p
from momakitchen.robots.body import RobotBody
from momakitchen.robots.urdf import BASE_LINK

# Per process and robot (``RobotBody.cache_key``: the name, ``name@height`` at another mount
# height): link index pairs tested for self-collision (-1 = base).
SELF_PAIRS_CACHE: dict[str, list[tuple[int, int]]] = {}


@dataclass(frozen=True)
class Contact:
    """A collision found by :meth:`Robot.arm_collisions`.

    Attributes:
        link: robot link name (``"mobile_base"`` for the base).
        body: the other body id (the robot's own id for a self-collision).
        other_link: link index on the other body (-1 = its base).
        distance: signed distance in metres (negative = penetration).
    """

    link: str
    body: int
    other_link: int
    distance: float


def base_collisions(robot: RobotBody, bodies: Iterable[int], margin: float = 0.0) -> list[int]:
    """Bodies among ``bodies`` within ``margin`` of the base (footprint box and pillar)."""
    hits = []
    for b in bodies:
        if b == robot.body:
            continue
        if p.getClosestPoints(robot.body, b, margin, linkIndexA=-1, physicsClientId=robot.client):
            hits.append(b)
    return hits


def arm_collisions(
    robot: RobotBody,
    bodies: Iterable[int],
    *,
    allow: Iterable[int | tuple[int, int]] = (),
    margin: float = 0.0,
    self_collision: bool = True,
) -> list[Contact]:
    """Collisions of the arm and tool with ``bodies`` (and with the robot itself).

    Args:
        bodies: world bodies to test (the floor may be included; the base is not
            tested here, see :meth:`base_collisions`).
        allow: intended contacts: a body id or a ``(body, link)`` pair that the
            end-effector links may touch (the target). The arm links may not.
        margin: report pairs closer than this (metres); 0 = touching/penetrating.
        self_collision: also test arm links against the base and non-adjacent links.
    """
    allowed_bodies, allowed_pairs = set(), set()
    for a in allow:
        if isinstance(a, tuple):
            allowed_pairs.add((int(a[0]), int(a[1])))
        else:
            allowed_bodies.add(int(a))
    out = []
    c = robot.client
    for b in bodies:
        if b == robot.body:
            continue
        for pt in p.getClosestPoints(robot.body, b, margin, physicsClientId=c):
            link, other = pt[3], pt[4]
            if link == -1:
                continue
            if link in robot.ee_links and (b in allowed_bodies or (b, other) in allowed_pairs):
                continue
            out.append(Contact(robot.link_names[link], b, other, float(pt[8])))
    if self_collision:
        for la, lb in self_pairs(robot):
            pts = p.getClosestPoints(
                robot.body, robot.body, margin, linkIndexA=la, linkIndexB=lb, physicsClientId=c
            )
            if pts:
                name = BASE_LINK if la == -1 else robot.link_names[la]
                out.append(Contact(name, robot.body, lb, float(min(x[8] for x in pts))))
    return out


def self_pairs(robot: RobotBody) -> list[tuple[int, int]]:
    """Link pairs tested for self-collision: not within two joints of each other and
    not touching at the home configuration (like an SRDF's disabled pairs)."""
    if robot.cache_key in SELF_PAIRS_CACHE:
        return SELF_PAIRS_CACHE[robot.cache_key]
    c = robot.client
    n = len(robot.link_names)
    links = [-1] + [
        j for j in range(n) if p.getCollisionShapeData(robot.body, j, physicsClientId=c)
    ]

    def hops(a: int, b: int) -> int:
        def up(j):
            path = [j]
            while j >= 0:
                j = robot._parent[j]
                path.append(j)
            return path

        pa, pb = up(a), up(b)
        common = next(x for x in pa if x in pb)
        return pa.index(common) + pb.index(common)

    saved = robot.joint_positions()
    saved_fingers = [
        p.getJointState(robot.body, j, physicsClientId=c)[0] for j in robot.finger_joints
    ]
    robot._reset_arm(robot.home)
    pairs = []
    for i, a in enumerate(links):
        for b in links[i + 1 :]:
            # Fingers and palm move against each other by design.
            if a in robot.ee_links and b in robot.ee_links:
                continue
            if hops(a, b) <= 2:
                continue
            if p.getClosestPoints(
                robot.body, robot.body, 0.0, linkIndexA=a, linkIndexB=b, physicsClientId=c
            ):
                continue
            pairs.append((a, b))
    robot._reset_arm(saved)
    for j, v in zip(robot.finger_joints, saved_fingers, strict=True):
        p.resetJointState(robot.body, j, v, physicsClientId=c)
    SELF_PAIRS_CACHE[robot.cache_key] = pairs
    return pairs
