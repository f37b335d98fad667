"""Grippers of another strength (``NAME-fN``): built from the name on first use, their
fingers squeezing with that force in physics, the force in the descriptor, bad names
refused."""

from __future__ import annotations

import numpy as np
import pytest

from momakitchen.bullet import p
from momakitchen.errors import MomaError
from momakitchen.robots import ROBOTS, get_robot_spec
from momakitchen.robots.descriptor import robot_descriptor
from momakitchen.robots.grip import grip_name, parse_grip_name
from momakitchen.robots.robot import Robot
from momakitchen.robots.spec import finger_force


def test_name_round_trip_and_non_names():
    assert grip_name("realman", 40.0) == "realman-f40"
    assert parse_grip_name("realman-f40") == ("realman", 40.0)
    assert parse_grip_name("realman-x0.72-f120") == ("realman-x0.72", 120.0)
    for name in ("realman", "realman-f4", "realman-f1000", "realman-40", "realman-f40.5"):
        assert parse_grip_name(name) is None, name


@pytest.mark.parametrize("name", ["realman-f40", "realman-x0.72-f40", "panda-f120"])
def test_a_variant_is_its_base_with_another_force(name):
    base = get_robot_spec(name.rsplit("-f", 1)[0])
    spec = get_robot_spec(name)
    assert spec.name in ROBOTS  # registered on first use
    force = float(name.rsplit("-f", 1)[1])
    assert finger_force(spec) == force != finger_force(base)
    assert (spec.reach, spec.dof, spec.mount_height, spec.model.arm, spec.model.home) == (
        base.reach,
        base.dof,
        base.mount_height,
        base.model.arm,
        base.model.home,
    )
    assert robot_descriptor(spec)[:4] == robot_descriptor(base)[:4]
    assert robot_descriptor(spec)[4] == pytest.approx(force / 100)


@pytest.mark.parametrize(
    ("name", "message"),
    [
        ("ur5e-f40", "only parallel grippers have a finger force; 'ur5e' has a suction cup"),
        ("realman-f300", r"finger force must be in \[10, 200\] N, got 300"),
        ("realman-f05", r"finger force must be in \[10, 200\] N, got 5"),
        ("nosuch-f40", "unknown robot 'nosuch-f40'"),
    ],
)
def test_bad_variants_are_refused(name, message):
    with pytest.raises(MomaError, match=message):
        get_robot_spec(name)
    assert name not in ROBOTS


def _squeeze(client: int, name: str) -> float:
    """The mean normal force (N) each finger of robot ``name`` presses on a fixed block
    held between its fingers once they have closed."""
    robot = Robot(client, name)
    try:
        pos, orn = robot.tcp_pose()
        half = [0.02, 0.02, 0.02]  # narrower than the open fingers in every direction
        shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=client)
        block = p.createMultiBody(
            0.0, shape, basePosition=pos, baseOrientation=orn, physicsClientId=client
        )
        robot.close_gripper()
        for _ in range(240):
            p.stepSimulation(physicsClientId=client)
        assert robot.is_grasping(block)
        forces = [
            sum(
                c[9]
                for c in p.getContactPoints(robot.body, block, linkIndexA=j, physicsClientId=client)
            )
            for j in robot.tool.finger_joints
        ]
        p.removeBody(block, physicsClientId=client)
        return float(np.mean(forces))
    finally:
        robot.remove()


def test_the_fingers_squeeze_with_the_variants_force(client):
    strong, weak = _squeeze(client, "realman"), _squeeze(client, "realman-f40")
    assert strong == pytest.approx(80.0, rel=0.15)
    assert weak == pytest.approx(40.0, rel=0.15)


def test_a_generation_config_takes_variants():
    from momakitchen.scene.configuration import SceneConfig

    config = SceneConfig(robots=("realman-f40", "flexiv-x0.83-f40"))
    assert config.robot_names == ("realman-f40", "flexiv-x0.83-f40")
    with pytest.raises(MomaError, match="only parallel grippers"):
        SceneConfig(robots=("ur5e-f40",))
