"""Manipulation primitives executed in physics: grasp-and-lift, suction pick.

Both step the robot's PyBullet client (gravity and the world are the caller's) and
report what physically happened to the object, never what was commanded.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from momakitchen.bullet import p
from momakitchen.robots.robot import Robot

# TCP z axis pointing down (rotation by pi about world x): the top-down approach.
TOP_DOWN = (1.0, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class PickOutcome:
    """What a pick did.

    Attributes:
        planned: every motion had an IK solution.
        attached: the gripper held the object (both fingers pressing) or the cup sealed.
        lifted: the object rose by at least half the lift height.
        rise: measured rise of the object in metres.
    """

    planned: bool
    attached: bool
    lifted: bool
    rise: float


def _z(body: int, client: int) -> float:
    return float(p.getBasePositionAndOrientation(body, physicsClientId=client)[0][2])


def _settle(robot: Robot, steps: int) -> None:
    for _ in range(steps):
        p.stepSimulation(physicsClientId=robot.client)


def grasp_and_lift(robot: Robot, body: int, grasp: Sequence[float],
                   orientation: Sequence[float] = TOP_DOWN, *, approach: float = 0.12,
                   lift: float = 0.15) -> PickOutcome:
    """Parallel-gripper pick: pre-grasp above, descend, close, lift.

    Args:
        body: the object (its base position is tracked).
        grasp: TCP position of the grasp in the world frame, shape ``(3,)``.
        orientation: TCP quaternion of the grasp (default: top-down).
        approach: the pre-grasp is this far back along the TCP z axis, metres.
        lift: lift height in metres.
    """
    c = robot.client
    grasp = np.asarray(grasp, float)
    rot = np.array(p.getMatrixFromQuaternion(orientation)).reshape(3, 3)
    pre = grasp - approach * rot[:, 2]
    res = robot.solve_ik(pre, orientation, seed=robot.home)
    if not res.success:
        return PickOutcome(False, False, False, 0.0)
    robot.set_joint_positions(res.q)
    robot.set_gripper_opening(robot.max_opening)
    _settle(robot, 30)
    z0 = _z(body, c)
    if not robot.move_tcp(grasp, orientation, n=8, steps_per_waypoint=30):
        return PickOutcome(False, False, False, 0.0)
    robot.close_gripper()
    _settle(robot, 120)
    attached = robot.is_grasping(body)
    planned = robot.move_tcp(grasp + np.array([0.0, 0.0, lift]), orientation, n=10,
                             steps_per_waypoint=30)
    _settle(robot, 60)
    rise = _z(body, c) - z0
    return PickOutcome(planned, attached, rise > 0.5 * lift, rise)


def suction_pick(robot: Robot, body: int, contact: Sequence[float],
                 orientation: Sequence[float] = TOP_DOWN, *, approach: float = 0.1,
                 lift: float = 0.15) -> PickOutcome:
    """Suction pick: approach, bring the cup face to ``contact``, suction on, lift.

    Args:
        contact: TCP (cup face) position at the moment suction is switched on, ``(3,)``.
    """
    c = robot.client
    contact = np.asarray(contact, float)
    rot = np.array(p.getMatrixFromQuaternion(orientation)).reshape(3, 3)
    pre = contact - approach * rot[:, 2]
    res = robot.solve_ik(pre, orientation, seed=robot.home)
    if not res.success:
        return PickOutcome(False, False, False, 0.0)
    robot.set_joint_positions(res.q)
    _settle(robot, 30)
    z0 = _z(body, c)
    if not robot.move_tcp(contact, orientation, n=8, steps_per_waypoint=30):
        return PickOutcome(False, False, False, 0.0)
    attached = robot.suction_on() == body
    planned = robot.move_tcp(contact + np.array([0.0, 0.0, lift]), orientation, n=10,
                             steps_per_waypoint=30)
    _settle(robot, 60)
    rise = _z(body, c) - z0
    return PickOutcome(planned, attached, rise > 0.5 * lift, rise)
