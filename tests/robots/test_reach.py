"""Reach (``robots/reach.py``): measured workspace radii and the cheap pre-check."""

from __future__ import annotations

import numpy as np
import pytest

from momakitchen.robots import get_robot_spec
from momakitchen.robots.reach import measure_workspace
from momakitchen.robots.robot import Robot

NAMES = ["panda", "flexiv", "ur5e", "xarm6", "realman", "elephant", "ur10e", "gen3"]


@pytest.mark.parametrize("name", NAMES)
def test_workspace_exceeds_manufacturer_reach_modestly(client, name):
    """Measured flange reach within 0.95-1.25 x the manufacturer's figure."""
    robot = Robot(client, name)
    flange, tcp = robot.workspace()
    reach = get_robot_spec(name).reach
    assert 0.95 * reach <= flange <= 1.25 * reach
    tool = float(np.linalg.norm(robot.tcp_pose()[0] - robot.flange_pose()[0]))
    assert tcp == pytest.approx(flange + tool, abs=0.03)


@pytest.mark.parametrize("name", NAMES)
def test_reach_precheck_never_rejects_reachable_poses(client, name):
    """could_reach is a necessary condition: every FK pose passes it, at any base pose."""
    robot = Robot(client, name, base=(0.4, -1.2, 2.0))
    rng = np.random.default_rng(3)
    for _ in range(300):
        pos, orn = robot.tcp_pose(rng.uniform(robot.lower, robot.upper))
        assert robot.could_reach(pos) and robot.could_reach(pos, orn)


def test_measure_workspace_restores_the_arm_and_grows_with_samples(client):
    robot = Robot(client, "xarm6")
    q = robot.joint_positions()
    few = measure_workspace(robot, 50)
    assert np.array_equal(robot.joint_positions(), q)
    assert robot.workspace()[0] >= few[0] - 0.01  # 1500 samples find at least as far
