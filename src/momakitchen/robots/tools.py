"""End-effectors in use: a parallel gripper or a suction cup, held by a Robot as
``robot.tool``.

Both act through PyBullet on the robot's body in the robot's client. A gripper's fingers
are prismatic joints with their own motors (PyBullet ignores URDF mimic joints); a
suction cup attaches a body with a fixed constraint, and only when a surface touches the
cup face. ``holds(body)`` is the common question of the trials: is the tool holding it?
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np

from momakitchen.bullet import p
from momakitchen.errors import MomaError
from momakitchen.robots.body import RobotBody


class ParallelGripperTool:
    """Two prismatic fingers closing along the TCP y axis.

    Args:
        robot: the robot the gripper is mounted on.
        finger_joints: joint indices of the fingers.
        max_opening: distance between the finger pads when fully open, metres.
        finger_force: closing force per finger, newtons.
    """

    kind = "parallel_gripper"

    def __init__(
        self, robot: RobotBody, finger_joints: list[int], max_opening: float, finger_force: float
    ) -> None:
        self.robot = robot
        self.finger_joints = finger_joints
        self.max_opening = max_opening
        self.finger_force = finger_force

    def opening(self) -> float:
        """Distance between the finger pads in metres."""
        r = self.robot
        states = p.getJointStates(r.body, self.finger_joints, physicsClientId=r.client)
        return float(sum(s[0] for s in states))

    def set_opening(self, opening: float) -> None:
        """Teleport the fingers to ``opening`` metres apart and hold them there."""
        r = self.robot
        half = float(np.clip(opening, 0.0, self.max_opening)) / 2
        for j in self.finger_joints:
            p.resetJointState(r.body, j, half, physicsClientId=r.client)
        self._drive(half)

    def _drive(self, half: float) -> None:
        # PyBullet ignores URDF mimic joints: each finger has its own motor.
        n = len(self.finger_joints)
        p.setJointMotorControlArray(
            self.robot.body,
            self.finger_joints,
            p.POSITION_CONTROL,
            targetPositions=[half] * n,
            forces=[self.finger_force] * n,
            physicsClientId=self.robot.client,
        )

    def open(self) -> None:
        """Command the fingers fully open (takes effect as physics steps)."""
        self._drive(self.max_opening / 2)

    def close(self) -> None:
        """Command the fingers closed with their force limit (takes effect as physics
        steps; an object between the fingers stops them)."""
        self._drive(0.0)

    def settle(self, max_steps: int = 60) -> None:
        """Step physics, 5 steps at a time, until the fingers have stopped (an object
        between them stops them early) or ``max_steps`` have run."""
        r = self.robot
        for _ in range(max_steps // 5):
            for _ in range(5):
                p.stepSimulation(physicsClientId=r.client)
            speeds = [
                abs(s[1])
                for s in p.getJointStates(r.body, self.finger_joints, physicsClientId=r.client)
            ]
            if max(speeds) < 1e-3:
                break

    def is_grasping(
        self, body: int, min_force: float = 0.5, max_angle: float = math.radians(85)
    ) -> bool:
        """Both fingers press on ``body``: at least ``min_force`` newtons each, along
        contact normals within ``max_angle`` of the finger's closing direction (a tip
        resting on the object is not a grasp; ManiSkill's test has the same shape)."""
        r = self.robot
        c = r.client
        cos_max = math.cos(max_angle)
        for j in self.finger_joints:
            # Opening direction of this finger in the world (its prismatic axis).
            _, orn = r.link_pose(j)
            local = np.asarray(p.getJointInfo(r.body, j, physicsClientId=c)[13], float)
            opening = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3) @ local
            force = 0.0
            for pt in p.getContactPoints(r.body, body, linkIndexA=j, physicsClientId=c):
                # The normal on the object points from the object to the finger, i.e. along
                # the finger's opening direction when the finger squeezes the object.
                if float(np.dot(pt[7], opening)) >= cos_max:
                    force += pt[9]
            if force < min_force:
                return False
        return True

    def holds(self, body: int) -> bool:
        """Whether the gripper holds ``body`` (:meth:`is_grasping` with its defaults)."""
        return self.is_grasping(body)


class SuctionTool:
    """A suction cup on the link ``cup_link``.

    Args:
        robot: the robot the cup is mounted on.
        cup_link: link index of the cup.
        contact_distance: a surface within this distance of the cup attaches, metres.
        face_link: the link whose frame lies on the cup face, z out of it (the TCP).
        face_tolerance: only contacts at most this far behind the face's plane count, not
            those on the cup's rim or along the side of a long stem, metres.
    """

    kind = "suction"

    # The narrowest surface the cup seals on (m): a handle, not the edge of a pot's wall.
    min_surface_width = 0.015

    def __init__(
        self,
        robot: RobotBody,
        cup_link: int,
        contact_distance: float,
        face_link: int,
        face_tolerance: float,
    ) -> None:
        self.robot = robot
        self.cup_link = cup_link
        self.contact_distance = contact_distance
        self.face_link = face_link
        self.face_tolerance = face_tolerance
        self._attachment: tuple[int, int] | None = None  # (constraint id, body)

    @property
    def attached_body(self) -> int | None:
        """Body held by the cup, or None."""
        return None if self._attachment is None else self._attachment[1]

    def on(self, bodies: Iterable[int] | None = None) -> int | None:
        """Switch suction on: attach the nearest body whose surface touches the cup face.

        Attaches (a fixed constraint holding the current relative pose) only if a surface
        is within the cup's contact distance of the cup face; otherwise nothing happens.

        Args:
            bodies: candidate bodies (default: every other body in the client).
        Returns:
            the attached body id, or None.
        """
        if self._attachment is not None:
            return self._attachment[1]
        r = self.robot
        c = r.client
        reach = self.contact_distance
        if bodies is None:
            bodies = [
                p.getBodyUniqueId(i, physicsClientId=c)
                for i in range(p.getNumBodies(physicsClientId=c))
            ]
        face_pos, face_orn = r.link_pose(self.face_link)
        face_z = np.array(p.getMatrixFromQuaternion(face_orn)).reshape(3, 3)[:, 2]
        best = None
        for b in bodies:
            if b == r.body:
                continue
            for pt in p.getClosestPoints(
                r.body, b, reach, linkIndexA=self.cup_link, physicsClientId=c
            ):
                # The contact must be on the cup face, not on its rim or side.
                if float((np.array(pt[5]) - face_pos) @ face_z) < -self.face_tolerance:
                    continue
                if best is None or pt[8] < best[2]:
                    best = (b, pt[4], pt[8])
        if best is None:
            return None
        body, link = best[0], best[1]
        # Constraint frames are relative to the links' centre-of-mass frames.
        st = p.getLinkState(r.body, self.cup_link, physicsClientId=c)
        cup_com = (st[0], st[1])
        if link == -1:
            obj_com = p.getBasePositionAndOrientation(body, physicsClientId=c)
        else:
            s2 = p.getLinkState(body, link, physicsClientId=c)
            obj_com = (s2[0], s2[1])
        inv_pos, inv_orn = p.invertTransform(obj_com[0], obj_com[1])
        rel_pos, rel_orn = p.multiplyTransforms(inv_pos, inv_orn, cup_com[0], cup_com[1])
        cid = p.createConstraint(
            r.body,
            self.cup_link,
            body,
            link,
            p.JOINT_FIXED,
            (0, 0, 0),
            (0, 0, 0),
            rel_pos,
            (0, 0, 0, 1),
            rel_orn,
            physicsClientId=c,
        )
        p.changeConstraint(cid, maxForce=200.0, physicsClientId=c)
        self._attachment = (cid, body)
        return body

    def off(self) -> None:
        """Release whatever the cup holds."""
        if self._attachment is not None:
            p.removeConstraint(self._attachment[0], physicsClientId=self.robot.client)
            self._attachment = None

    def holds(self, body: int) -> bool:
        """Whether the cup holds ``body``."""
        return self.attached_body == body


Tool = ParallelGripperTool | SuctionTool


def make_tool(robot: RobotBody) -> Tool:
    """The tool of a loaded robot (its joints indexed), from its model's end-effector."""
    ee = robot.model.end_effector
    finger_joints, infos = robot.finger_joints, robot._joint_infos
    if robot.spec.end_effector == "parallel_gripper":
        if not finger_joints:
            raise MomaError(f"robot {robot.name!r}: a parallel gripper needs finger joints")
        # Fully open: both fingers at their upper limits.
        max_opening = float(sum(infos[j][9] for j in finger_joints))
        return ParallelGripperTool(robot, finger_joints, max_opening, ee.finger_force)
    return SuctionTool(
        robot, cup_link(robot), ee.contact_distance, robot.tcp_link, ee.face_tolerance
    )


def cup_link(robot: RobotBody) -> int:
    """The link that carries a user's suction cup: the nearest link at or above the TCP
    frame that has collision geometry. A ROS-style TCP frame (``tool0``) has none, and
    PyBullet finds no contact on a link without geometry: such a cup would never attach."""
    c = robot.client
    link = robot.tcp_link
    while link >= 0 and not p.getCollisionShapeData(robot.body, link, physicsClientId=c):
        link = robot._parent[link]
    if link < 0:
        raise MomaError(
            f"robot {robot.name!r}: no link with collision geometry carries the suction TCP "
            f"{robot.model.end_effector.tcp_link!r}"
        )
    return link
