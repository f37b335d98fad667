"""The tools (``robots/tools.py``): gripper fingers and suction cup, kinematically and in
physics (gravity, friction, motors; no kinematic shortcuts for holding)."""

from __future__ import annotations

import numpy as np
import pytest

from momakitchen.bullet import p
from momakitchen.errors import MomaError
from momakitchen.robots import get_robot_spec
from momakitchen.robots.robot import Robot
from momakitchen.robots.tools import ParallelGripperTool, SuctionTool

TOP_DOWN = (1.0, 0.0, 0.0, 0.0)  # TCP z axis pointing down (pi about world x)


def test_gripper_opening(client):
    robot = Robot(client, "flexiv")
    assert robot.gripper_opening() == pytest.approx(0.08)
    robot.set_gripper_opening(0.03)
    assert robot.gripper_opening() == pytest.approx(0.03)
    # The finger pads really are that far apart (inner faces along the TCP y axis).
    left = robot.link_pose(robot.link_index("finger_left"))[0]
    right = robot.link_pose(robot.link_index("finger_right"))[0]
    assert np.linalg.norm(left - right) == pytest.approx(0.03, abs=1e-6)
    with pytest.raises(MomaError, match="no suction cup"):
        robot.suction_on()


def test_suction_attaches_only_on_cup_face_contact(client, box):
    robot = Robot(client, "ur5e")
    robot.set_joint_positions(robot.home)  # tool pointing down
    tcp, _ = robot.tcp_pose()
    with pytest.raises(MomaError, match="no gripper"):
        robot.close_gripper()
    gap = box((0.04, 0.04, 0.02), tcp - np.array([0, 0, 0.02 + 0.02]), mass=0.2)
    assert robot.suction_on() is None and robot.attached_body is None
    p.removeBody(gap, physicsClientId=client)
    beside = box((0.04, 0.04, 0.04), tcp + np.array([0.061, 0, 0]), mass=0.2)
    assert robot.suction_on() is None  # touching the cup's side is not a seal
    p.removeBody(beside, physicsClientId=client)
    touching = box((0.04, 0.04, 0.02), tcp - np.array([0, 0, 0.02 + 0.001]), mass=0.2)
    assert robot.suction_on() == touching == robot.attached_body
    robot.suction_off()
    assert robot.attached_body is None


def _table_world(client: int, name: str, half: tuple[float, float, float], mass: float):
    """Gravity, ``name`` at the origin facing +x, a table top 0.45 m below its shoulder and
    an object on it at x = min(0.5, 0.65 reach); returns ``(robot, table, obj, x, top)``
    with ``top`` the height of the object's top face."""
    p.setGravity(0, 0, -9.81, physicsClientId=client)
    robot = Robot(client, name)
    height = float(robot.shoulder_position()[2]) - 0.45
    x = min(0.5, 0.65 * get_robot_spec(name).reach)
    col = p.createCollisionShape(
        p.GEOM_BOX, halfExtents=[0.3, 0.4, height / 2], physicsClientId=client
    )
    table = p.createMultiBody(0, col, basePosition=[0.65, 0, height / 2], physicsClientId=client)
    shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=list(half), physicsClientId=client)
    obj = p.createMultiBody(
        mass, shape, basePosition=[x, 0, height + half[2]], physicsClientId=client
    )
    p.changeDynamics(obj, -1, lateralFriction=1.0, physicsClientId=client)
    return robot, table, obj, x, height + 2 * half[2]


def _z(body: int, client: int) -> float:
    return float(p.getBasePositionAndOrientation(body, physicsClientId=client)[0][2])


def _lift(robot: Robot, lift: float = 0.15) -> None:
    """Move the TCP straight up by ``lift`` in physics (the tool as it is), then hold."""
    pos, orn = robot.tcp_pose()
    assert robot.move_tcp(pos + np.array([0.0, 0.0, lift]), orn, n=10, steps_per_waypoint=30)
    for _ in range(60):
        p.stepSimulation(physicsClientId=robot.client)


def _gripper_pick(client: int, close: bool) -> tuple[bool, float]:
    """Panda: fingers open around a 5 cm cube from above, close (or not), lift 15 cm;
    returns (held after closing, rise of the cube)."""
    robot, table, cube, x, top = _table_world(client, "panda", (0.025, 0.025, 0.025), 0.1)
    tool = robot.tool
    assert isinstance(tool, ParallelGripperTool)
    grasp = np.array([x, 0.0, top - 0.025])
    pre = robot.solve_ik(grasp + np.array([0.0, 0.0, 0.12]), TOP_DOWN, seed=robot.home)
    assert pre.success
    robot.set_joint_positions(pre.q)
    tool.set_opening(tool.max_opening)
    z0 = _z(cube, client)
    assert robot.move_tcp(grasp, TOP_DOWN, n=8, steps_per_waypoint=30)
    if close:
        tool.close()
    tool.settle(120)
    held = tool.holds(cube)
    _lift(robot)
    # The table stays put whatever happens to the cube.
    assert p.getBasePositionAndOrientation(table, physicsClientId=client)[0][2] == pytest.approx(
        (top - 0.05) / 2
    )
    return held, _z(cube, client) - z0


def test_gripper_holds_and_lifts_a_cube(client):
    held, rise = _gripper_pick(client, close=True)
    assert held and rise > 0.12


def test_gripper_left_open_lifts_nothing(client):
    """Control: the same motion without closing leaves the cube on the table."""
    held, rise = _gripper_pick(client, close=False)
    assert not held and abs(rise) < 0.01


def _suction_pick(client: int, gap: float) -> tuple[int | None, float]:
    """UR5e: bring the cup face ``gap`` above a box's top face, suction on, lift 15 cm;
    returns (attached body, rise of the box)."""
    robot, _, obj, x, top = _table_world(client, "ur5e", (0.04, 0.04, 0.02), 0.2)
    tool = robot.tool
    assert isinstance(tool, SuctionTool)
    contact = np.array([x, 0.0, top + gap])
    pre = robot.solve_ik(contact + np.array([0.0, 0.0, 0.1]), TOP_DOWN, seed=robot.home)
    assert pre.success
    robot.set_joint_positions(pre.q)
    z0 = _z(obj, client)
    assert robot.move_tcp(contact, TOP_DOWN, n=8, steps_per_waypoint=30)
    attached = tool.on()
    assert tool.holds(obj) == (attached == obj)
    _lift(robot)
    return attached, _z(obj, client) - z0


def test_suction_lifts_a_box_when_the_cup_touches(client):
    attached, rise = _suction_pick(client, 0.0)
    assert attached is not None and rise > 0.12


def test_suction_with_a_2cm_gap_lifts_nothing(client):
    attached, rise = _suction_pick(client, 0.02)
    assert attached is None and abs(rise) < 0.005
