"""Collisions (``robots/collisions.py``): base, arm with an allowed target, self."""

from __future__ import annotations

import math

from momakitchen.robots.robot import Robot
from momakitchen.robots.urdf import BASE_LINK


def test_base_collisions(client, box):
    robot = Robot(client, "panda")
    obstacle = box((0.1, 0.1, 0.2), (0.3, 0.0, 0.2))  # overlaps the front edge
    far = box((0.1, 0.1, 0.2), (1.0, 0.0, 0.2))
    assert robot.base_collisions([obstacle, far]) == [obstacle]
    robot.place_base(-1.0, 0.0, 0.0)
    assert robot.base_collisions([obstacle, far]) == []
    assert robot.base_collisions([far], margin=2.5) == [far]


def test_arm_collisions_allow_the_target_for_the_tool_only(client, box):
    robot = Robot(client, "panda")
    tcp, _ = robot.tcp_pose()
    target = box((0.06, 0.06, 0.02), tcp)  # wider than the open fingers
    hits = robot.arm_collisions([target])
    assert hits and all(h.body == target for h in hits)
    assert robot.arm_collisions([target], allow=[target]) == []
    assert robot.arm_collisions([target], allow=[(target, -1)]) == []
    # An obstacle at the elbow is a collision even if it is the allowed target.
    elbow = robot.link_pose(robot.arm_joints[3])[0]
    blocker = box((0.05, 0.05, 0.05), elbow)
    hits = robot.arm_collisions([blocker], allow=[blocker])
    assert hits and not any(robot.link_index(h.link) in robot.ee_links for h in hits)


def test_self_collision_with_base(client):
    robot = Robot(client, "ur5e")
    robot.set_joint_positions([0, math.pi / 2, 0, 0, 0, 0])  # upper arm straight down
    hits = robot.arm_collisions([])
    assert any(h.link == BASE_LINK and h.body == robot.body for h in hits)
    assert robot.arm_collisions([], self_collision=False) == []
