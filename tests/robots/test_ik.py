"""Inverse kinematics (``robots/ik.py``): FK -> IK -> FK round trips, the reach pre-check,
straight-line plans."""

from __future__ import annotations

import math

import numpy as np
import pytest

from momakitchen.errors import MomaError
from momakitchen.robots.ik import build_seed_library
from momakitchen.robots.robot import Robot, quaternion_angle

NAMES = ["panda", "flexiv", "ur5e", "xarm6", "realman", "elephant", "ur10e", "gen3"]


@pytest.mark.parametrize("name", NAMES)
def test_ik_round_trip(client, name):
    """FK -> IK -> FK within 5 mm and 2 degrees on reachable poses (IK seeded at home)."""
    robot = Robot(client, name, base=(0.3, 0.2, 0.5))
    rng = np.random.default_rng(7)
    successes = 0
    for _ in range(12):
        q = rng.uniform(robot.lower, robot.upper)
        pos, orn = robot.tcp_pose(q)
        res = robot.solve_ik(pos, orn, seed=robot.home, rng=rng)
        assert robot.within_limits(res.q)
        got_pos, got_orn = robot.tcp_pose(res.q)
        # The reported residuals are the measured ones.
        assert float(np.linalg.norm(got_pos - pos)) == pytest.approx(res.position_error, abs=1e-6)
        if res.success:
            successes += 1
            assert np.linalg.norm(got_pos - pos) <= 0.005
            assert quaternion_angle(got_orn, orn) <= math.radians(2)
            assert np.allclose(robot.joint_positions(), res.q)  # left at the answer
    assert successes >= 9


def test_ik_position_only_and_unreachable(client):
    robot = Robot(client, "ur5e")
    sh = robot.shoulder_position()
    res = robot.solve_ik(sh + np.array([0.5, 0.1, -0.2]))
    assert res.success and res.orientation_error == 0.0
    far = robot.solve_ik(sh + np.array([3.0, 0.0, 0.0]), (1, 0, 0, 0))
    assert not far.success and far.position_error > 1.5
    assert far.calls == 0  # rejected by the reach pre-check: no iteration of the solver
    assert not robot.could_reach(sh + np.array([3.0, 0.0, 0.0]))
    assert robot.could_reach(sh + np.array([0.5, 0.0, 0.0]))
    # At the edge of the TCP sphere, pointing down puts the flange out of its own sphere.
    tcp_reach = robot.workspace()[1]
    edge = sh + np.array([tcp_reach - 0.02, 0.0, 0.0])
    assert robot.could_reach(edge)
    assert not robot.could_reach(edge, (1, 0, 0, 0))
    assert robot.could_reach(edge, (0, 0.7071068, 0, 0.7071068))  # pointing outwards
    res = robot.solve_ik(edge, (1, 0, 0, 0))
    assert not res.success and res.calls == 0
    with pytest.raises(MomaError, match="unit quaternion"):
        robot.solve_ik(sh, (0, 0, 0, 0))


def test_plan_line_follows_a_straight_line_and_keeps_the_joint_state(client):
    robot = Robot(client, "panda")
    q0 = robot.joint_positions()
    start, orn = robot.tcp_pose()
    goal = start + np.array([0.05, 0.0, -0.05])
    path = robot.plan_line(goal, orn, n=5)
    assert path is not None and len(path) == 5
    for k, q in enumerate(path, start=1):
        pos, _ = robot.tcp_pose(q)
        assert np.linalg.norm(pos - (start + (goal - start) * k / 5)) <= 0.005
    assert np.array_equal(robot.joint_positions(), q0)
    assert robot.plan_line(start + np.array([3.0, 0.0, 0.0]), orn) is None  # out of reach


@pytest.mark.parametrize("name", ["elephant", "panda"])
def test_seed_library_holds_no_self_colliding_configurations(client, name):
    """IK restarts from library configurations: one that folds the arm into its own base
    led the solver to answers that did the same (the Elephant reaching down to a fridge
    handle)."""
    robot = Robot(client, name)
    qs, pos, zax = build_seed_library(robot, n=200)
    assert len(qs) == 200 and pos.shape == zax.shape == (200, 3)
    for q in qs:
        robot.set_joint_positions(q)
        assert not robot.arm_collisions([]), q
