"""The Robot facade: loading, placement, joints, FK, tools, independent clients."""

from __future__ import annotations

import math

import numpy as np
import pytest

from momakitchen.bullet import p
from momakitchen.errors import MomaError
from momakitchen.robots import get_robot_spec
from momakitchen.robots.robot import Robot, quaternion_angle
from momakitchen.robots.tools import ParallelGripperTool, SuctionTool

NAMES = ["panda", "flexiv", "ur5e", "xarm6", "realman", "elephant", "ur10e", "gen3"]


def test_unknown_robot_is_a_moma_error(client):
    with pytest.raises(MomaError, match="unknown robot 'nope'"):
        Robot(client, "nope")


@pytest.mark.parametrize("name", NAMES)
def test_structure_matches_spec(client, name):
    robot = Robot(client, name)
    spec = get_robot_spec(name)
    assert robot.dof == spec.dof == len(robot.joint_names)
    assert np.all(robot.lower < robot.upper)
    assert robot.within_limits(robot.home)
    # Arm mounted at the mount height: the arm's base frame sits on the pillar top.
    first = robot.arm_joints[0]
    parent = robot._parent[first]
    z = robot.link_pose(parent)[0][2]
    assert z == pytest.approx(spec.mount_height, abs=1e-6)
    # One tool, of the kind the spec names; the facade's attributes read it.
    assert robot.tool.kind == spec.end_effector
    if spec.end_effector == "suction":
        assert isinstance(robot.tool, SuctionTool)
        assert robot.cup_link == robot.tool.cup_link is not None and not robot.finger_joints
    else:
        assert isinstance(robot.tool, ParallelGripperTool)
        assert len(robot.finger_joints) == 2 and robot.cup_link is None
        assert robot.max_opening == robot.tool.max_opening == pytest.approx(0.08)
    # No self-collision at home.
    assert robot.arm_collisions([]) == []


def test_place_base_moves_everything_rigidly(client):
    robot = Robot(client, "panda")
    q = robot.home
    robot.set_joint_positions(q)
    pos0, orn0 = robot.tcp_pose()
    robot.place_base(1.5, -0.7, math.pi / 3)
    assert robot.base_pose() == pytest.approx((1.5, -0.7, math.pi / 3), abs=1e-9)
    pos1, orn1 = robot.tcp_pose()
    c, s = math.cos(math.pi / 3), math.sin(math.pi / 3)
    want = np.array([c * pos0[0] - s * pos0[1] + 1.5, s * pos0[0] + c * pos0[1] - 0.7, pos0[2]])
    assert np.allclose(pos1, want, atol=1e-6)
    assert quaternion_angle(orn0, orn1) == pytest.approx(math.pi / 3, abs=1e-6)
    # The base stays on the floor.
    assert robot.link_pose(-1)[0][2] == pytest.approx(0.0, abs=1e-9)


def test_joint_positions_round_trip_and_validation(client):
    robot = Robot(client, "realman")
    q = np.array([0.1, 0.5, 1.0, -0.3, 0.8, 0.2])
    robot.set_joint_positions(q)
    assert np.allclose(robot.joint_positions(), q)
    with pytest.raises(MomaError, match="expected 6 joint values"):
        robot.set_joint_positions([0.0] * 5)
    # FK at a given q does not disturb the current configuration.
    robot.tcp_pose(np.zeros(6))
    assert np.allclose(robot.joint_positions(), q)


def test_independent_clients_in_one_process():
    a, b = p.connect(p.DIRECT), p.connect(p.DIRECT)
    try:
        ra, rb = Robot(a, "panda"), Robot(b, "ur5e")
        rb2 = Robot(b, "panda", base=(2.0, 0.0, 0.0))
        ra.place_base(5.0, 5.0, 1.0)
        assert rb2.base_pose() == pytest.approx((2.0, 0.0, 0.0))
        for robot in (ra, rb, rb2):
            pos, orn = robot.tcp_pose()
            res = robot.solve_ik(pos + np.array([0.0, 0.05, -0.05]), orn)
            assert res.success
        assert p.getNumBodies(physicsClientId=a) == 1
        assert p.getNumBodies(physicsClientId=b) == 2
    finally:
        p.disconnect(a)
        p.disconnect(b)


def _pybullet_ik(robot, client):
    """PyBullet's own null-space IK on a robot, as a caller of the PyBullet API might."""
    movable = robot._movable
    infos = [p.getJointInfo(robot.body, j, physicsClientId=client) for j in movable]
    lower, upper = [i[8] for i in infos], [i[9] for i in infos]
    ranges = [max(h - lo, 1e-3) for lo, h in zip(lower, upper, strict=True)]
    pos, orn = robot.tcp_pose()
    for _ in range(4):
        p.calculateInverseKinematics(
            robot.body,
            robot.tcp_link,
            pos,
            orn,
            lowerLimits=lower,
            upperLimits=upper,
            jointRanges=ranges,
            restPoses=[0.0] * len(movable),
            currentPositions=[0.0] * len(movable),
            maxNumIterations=30,
            physicsClientId=client,
        )


@pytest.mark.parametrize(
    ("first", "second"), [("flexiv", "elephant"), ("xarm6", "flexiv"), ("elephant", "flexiv")]
)
def test_reloading_a_different_robot_in_a_reused_body_slot(first, second):
    """PyBullet caches a kinematic tree per body and keeps it after removal, so its own IK
    and Jacobian can go stale for the second robot (whether it happens depends on memory
    reuse). The robot's IK uses link states only and keeps working."""
    client = p.connect(p.DIRECT)
    try:
        r1 = Robot(client, first)
        _pybullet_ik(r1, client)
        r1.remove()
        r2 = Robot(client, second)
        pos, orn = r2.tcp_pose()
        assert r2.solve_ik(pos + np.array([0.03, 0.0, 0.0]), orn).success
    finally:
        p.disconnect(client)
