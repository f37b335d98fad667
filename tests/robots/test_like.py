"""Robots like a built-in (a YAML with ``like: NAME``): its files with the fields given
changed: links scaled in the URDF (``link_scale``), another grip force (``finger_force``).
Their kinematics and fingers checked in physics, bad values refused."""

from __future__ import annotations

import numpy as np
import pytest

from momakitchen.bullet import p
from momakitchen.errors import MomaError
from momakitchen.robots import ROBOTS, get_robot_spec
from momakitchen.robots.descriptor import robot_descriptor
from momakitchen.robots.robot import Robot
from momakitchen.robots.spec import finger_force
from momakitchen.robots.user import (
    register_user_robot,
    register_user_robots,
    unregister_user_robot,
    user_robot_file,
)


@pytest.fixture
def like(tmp_path):
    """``like(name, **fields) -> spec``: a user robot ``name`` from a YAML of ``fields``."""
    names: list[str] = []

    def make(name: str, **fields):
        lines = [f"name: {name}"] + [f"{k}: {v}" for k, v in fields.items()]
        path = tmp_path / f"{name}.yaml"
        path.write_text("\n".join(lines) + "\n")
        spec = register_user_robot(path)
        names.append(name)
        return spec

    yield make
    for name in names:
        if name in ROBOTS:
            unregister_user_robot(name)


def test_like_alone_is_the_built_in_under_another_name(like):
    spec, base = like("my_flexiv", like="flexiv"), get_robot_spec("flexiv")
    assert spec.model.arm == base.model.arm and spec.model.end_effector == base.model.end_effector
    assert robot_descriptor(spec) == robot_descriptor(base)
    # Its record covers the built-in's YAML too: the robot changes when that file does.
    assert user_robot_file("my_flexiv") is not None


def test_a_scaled_arm_scales_lengths_and_reach_only(like):
    base = get_robot_spec("realman")
    spec = like("realman_x078", like="realman", link_scale=0.78)
    assert spec.reach == pytest.approx(0.78 * base.reach)  # the built-in's, scaled
    assert (spec.dof, spec.end_effector, spec.mount_height, spec.footprint) == (
        base.dof,
        base.end_effector,
        base.mount_height,
        base.footprint,
    )
    assert spec.model.home == base.model.home
    assert spec.model.end_effector == base.model.end_effector
    assert spec.model.arm.link_scale == 0.78
    assert robot_descriptor(spec)[0] == pytest.approx(0.78 * base.reach)
    # A reach the YAML gives is taken as given.
    assert like("realman_x078r", like="realman", link_scale=0.78, reach=0.7).reach == 0.7


@pytest.mark.parametrize(("base", "scale"), [("ur5e", 0.65), ("ur10e", 0.86), ("panda", 1.2)])
def test_scaled_forward_kinematics_is_the_original_scaled(client, like, base, scale):
    """At the same joint angles, the flange seen from the arm mount is the original's times
    the scale, for arms of primitives and of meshes alike; the tool stays as it is."""
    name = f"{base}_scaled"
    like(name, like=base, link_scale=scale)
    robots = {n: Robot(client, n) for n in (base, name)}
    try:
        rng = np.random.default_rng(7)
        for _ in range(10):
            q = rng.uniform(robots[base].lower, robots[base].upper)
            flange, tool = {}, {}
            for n, robot in robots.items():
                robot.set_joint_positions(q)
                spec = get_robot_spec(n)
                mount = np.array([spec.mount_offset_x, 0.0, spec.mount_height])
                flange[n] = robot.flange_pose()[0] - mount
                tool[n] = np.linalg.norm(robot.tcp_pose()[0] - robot.flange_pose()[0])
            assert np.allclose(flange[name], scale * flange[base], atol=1e-6)
            assert tool[name] == pytest.approx(tool[base], abs=1e-6)
        assert np.array_equal(robots[name].lower, robots[base].lower)
    finally:
        for robot in robots.values():
            robot.remove()


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


def test_the_fingers_squeeze_with_the_force_the_yaml_gives(client, like):
    spec = like("realman_f40", like="realman", finger_force=40)
    assert finger_force(spec) == 40.0 != finger_force(get_robot_spec("realman"))
    assert robot_descriptor(spec)[4] == pytest.approx(0.4)
    strong, weak = _squeeze(client, "realman"), _squeeze(client, "realman_f40")
    assert strong == pytest.approx(80.0, rel=0.15)
    assert weak == pytest.approx(40.0, rel=0.15)


@pytest.mark.parametrize(
    ("fields", "message"),
    [
        ({"like": "nosuch"}, "field 'like' must name a built-in robot"),
        ({"like": "ur5e", "link_scale": 1.6}, r"link_scale must be in \[0.5, 1.5\], got 1.6"),
        ({"like": "ur5e", "link_scale": 0.4}, r"link_scale must be in \[0.5, 1.5\], got 0.4"),
        ({"like": "ur5e", "finger_force": 40}, "finger_force is for grippers"),
        ({"like": "realman", "finger_force": 300}, r"finger_force must be in \[10, 200\] N"),
        ({"like": "realman", "suction_face_tolerance": 0.004}, "is for suction cups"),
    ],
)
def test_bad_fields_are_refused(like, fields, message):
    with pytest.raises(MomaError, match=message):
        like("bad_robot", **fields)
    assert "bad_robot" not in ROBOTS


def test_a_directory_registers_each_of_its_yaml_files(tmp_path):
    for name, scale in (("ur5e_a", 0.7), ("ur5e_b", 1.1)):
        (tmp_path / f"{name}.yaml").write_text(f"name: {name}\nlike: ur5e\nlink_scale: {scale}\n")
    try:
        specs = register_user_robots(tmp_path)
        assert [s.name for s in specs] == ["ur5e_a", "ur5e_b"]
    finally:
        for name in ("ur5e_a", "ur5e_b"):
            if name in ROBOTS:
                unregister_user_robot(name)
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(MomaError, match="holds no"):
        register_user_robots(empty)


def test_a_generation_config_takes_a_robot_like_a_built_in(like):
    from momakitchen.scene.configuration import SceneConfig

    like("ur5e_x065", like="ur5e", link_scale=0.65)
    config = SceneConfig(robots=("ur5e_x065",), mount_height=(0.45, 1.15))
    assert config.robot_names == ("ur5e_x065",)
    with pytest.raises(MomaError, match=r"unknown robot 'ur5e-x0\.65'"):
        SceneConfig(robots=("ur5e-x0.65",))
