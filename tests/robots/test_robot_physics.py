"""Manipulation in physics: grippers grasp and lift a 5 cm cube, suction lifts only on
contact. Real PyBullet dynamics (gravity, friction, motors), no kinematic shortcuts."""

from __future__ import annotations

import pytest

from momakitchen.bullet import p
from momakitchen.robots import get_robot_spec
from momakitchen.robots.robot import Robot
from momakitchen.robots.skills import grasp_and_lift, suction_pick

GRIPPER_ROBOTS = ["panda", "flexiv", "xarm6", "realman", "elephant"]


def make_world(name: str, half: tuple[float, float, float], mass: float):
    """A robot at the origin facing +x, a table in front, an object on the table.

    The table top is 0.45 m below the shoulder; the object sits at
    x = min(0.5, 0.65 reach) (within comfortable reach of every arm).
    """
    client = p.connect(p.DIRECT)
    p.setGravity(0, 0, -9.81, physicsClientId=client)
    robot = Robot(client, name)
    height = float(robot.shoulder_position()[2]) - 0.45
    x = min(0.5, 0.65 * get_robot_spec(name).reach)
    col = p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.3, 0.4, height / 2],
                                 physicsClientId=client)
    table = p.createMultiBody(0, col, basePosition=[0.65, 0, height / 2],
                              physicsClientId=client)
    box = p.createCollisionShape(p.GEOM_BOX, halfExtents=list(half), physicsClientId=client)
    obj = p.createMultiBody(mass, box, basePosition=[x, 0, height + half[2]],
                            physicsClientId=client)
    p.changeDynamics(obj, -1, lateralFriction=1.0, physicsClientId=client)
    return client, robot, table, obj, x, height


def _grasp(name: str):
    client, robot, table, cube, x, height = make_world(name, (0.025, 0.025, 0.025), 0.1)
    try:
        out = grasp_and_lift(robot, cube, [x, 0.0, height + 0.025], lift=0.15)
        # The table must not come along, and the fingers must really hold the cube.
        assert p.getBasePositionAndOrientation(table, physicsClientId=client)[0][2] == \
            pytest.approx(height / 2)
        return out, robot.is_grasping(cube)
    finally:
        p.disconnect(client)


def test_panda_grasps_and_lifts_cube():
    out, holding = _grasp("panda")
    assert out.planned and out.attached and holding
    assert out.lifted and out.rise > 0.12


@pytest.mark.slow
@pytest.mark.parametrize("name", [n for n in GRIPPER_ROBOTS if n != "panda"])
def test_gripper_robot_grasps_and_lifts_cube(name):
    out, holding = _grasp(name)
    assert out.planned and out.attached and holding, out
    assert out.lifted and out.rise > 0.12, out


def test_gripper_without_closing_lifts_nothing():
    """Control: the same motion with the fingers left open leaves the cube on the table."""
    client, robot, _, cube, x, height = make_world("panda", (0.025, 0.025, 0.025), 0.1)
    try:
        robot.close_gripper = robot.open_gripper  # the only change: never close
        out = grasp_and_lift(robot, cube, [x, 0.0, height + 0.025], lift=0.15)
        assert out.planned and not out.attached
        assert not out.lifted and abs(out.rise) < 0.01
    finally:
        p.disconnect(client)


def _suction(gap: float):
    half = (0.04, 0.04, 0.02)
    client, robot, _, box, x, height = make_world("ur5e", half, 0.2)
    try:
        top = height + 2 * half[2]
        out = suction_pick(robot, box, [x, 0.0, top + gap], lift=0.15)
        return out, robot.attached_body
    finally:
        p.disconnect(client)


def test_suction_lifts_box_when_cup_touches():
    out, attached = _suction(0.0)
    assert out.planned and out.attached and attached is not None
    assert out.lifted and out.rise > 0.12


def test_suction_with_2cm_gap_lifts_nothing():
    out, attached = _suction(0.02)
    assert out.planned and not out.attached and attached is None
    assert not out.lifted and abs(out.rise) < 0.005
