"""Arms with scaled links (``NAME-xS.SS``): built from the scaled joint table on first use,
their forward kinematics the original's scaled, bad names and scales refused."""

from __future__ import annotations

import numpy as np
import pytest

from momakitchen.bullet import p
from momakitchen.errors import MomaError
from momakitchen.robots import ROBOTS, get_robot_spec
from momakitchen.robots.descriptor import robot_descriptor
from momakitchen.robots.robot import Robot
from momakitchen.robots.scaled import parse_scaled_name, scaled_name


def test_name_round_trip_and_non_names():
    assert scaled_name("ur5e", 0.65) == "ur5e-x0.65"
    assert parse_scaled_name("ur5e-x0.65") == ("ur5e", 0.65)
    assert parse_scaled_name("ur10e-x1.15") == ("ur10e", 1.15)
    for name in ("ur5e", "ur5e-x0.7", "ur5e-x0.650", "ur5e-0.65", "-x0.65"):
        assert parse_scaled_name(name) is None, name


def test_scaled_spec_scales_lengths_only():
    base = get_robot_spec("realman")
    spec = get_robot_spec("realman-x0.78")
    assert spec.name in ROBOTS  # registered on first use
    assert spec.reach == pytest.approx(0.78 * base.reach)
    assert (spec.dof, spec.end_effector, spec.mount_height, spec.footprint) == (
        base.dof,
        base.end_effector,
        base.mount_height,
        base.footprint,
    )
    assert spec.model.home == base.model.home
    assert spec.model.end_effector == base.model.end_effector
    for a, b in zip(spec.model.arm.joints, base.model.arm.joints, strict=True):
        assert np.allclose(a.xyz, 0.78 * np.array(b.xyz))
        assert (a.rpy, a.axis, a.lower, a.upper, a.effort) == (
            b.rpy,
            b.axis,
            b.lower,
            b.upper,
            b.effort,
        )
    # The descriptor the model sees carries the scaled reach.
    assert robot_descriptor(spec)[0] == pytest.approx(0.78 * base.reach)


@pytest.mark.parametrize(
    ("name", "message"),
    [
        ("panda-x0.80", "only arms built from joint tables scale"),
        ("ur5e-x1.60", "link scale must be in [0.5, 1.5], got 1.6"),
        ("ur5e-x0.40", "link scale must be in [0.5, 1.5], got 0.4"),
        ("nosuch-x0.80", "unknown robot 'nosuch-x0.80'"),
        ("ur5e-x0.8", "unknown robot 'ur5e-x0.8'"),
    ],
)
def test_bad_scaled_names_are_refused(name, message):
    with pytest.raises(MomaError, match=message.replace("[", r"\[").replace("]", r"\]")):
        get_robot_spec(name)
    assert name not in ROBOTS


@pytest.fixture
def client():
    cid = p.connect(p.DIRECT)
    yield cid
    p.disconnect(cid)


@pytest.mark.parametrize(("base", "scale"), [("ur5e", 0.65), ("flexiv", 0.8), ("ur10e", 0.86)])
def test_scaled_forward_kinematics_is_the_original_scaled(client, base, scale):
    """At the same joint angles, the flange seen from the arm mount is the original's
    flange position times the scale (the arm base housing and joint origins scale alike)."""
    robots = {n: Robot(client, n) for n in (base, scaled_name(base, scale))}
    try:
        rng = np.random.default_rng(7)
        for _ in range(10):
            q = rng.uniform(robots[base].lower, robots[base].upper)
            got = {}
            for n, robot in robots.items():
                robot.set_joint_positions(q)
                spec = get_robot_spec(n)
                mount = np.array([spec.mount_offset_x, 0.0, spec.mount_height])
                got[n] = robot.flange_pose()[0] - mount
            assert np.allclose(got[scaled_name(base, scale)], scale * got[base], atol=1e-4)
    finally:
        for robot in robots.values():
            robot.remove()


def _reach_in_fresh_process(name: str) -> float:
    return get_robot_spec(name).reach


def test_a_fresh_process_builds_it_from_the_name_alone():
    """Generation workers and other commands know a scaled arm by its name only."""
    import multiprocessing

    with multiprocessing.get_context("spawn").Pool(1) as pool:
        reach = pool.apply(_reach_in_fresh_process, ("flexiv-x0.80",))
    assert reach == pytest.approx(0.8 * get_robot_spec("flexiv").reach)


def test_a_generation_config_takes_scaled_arms():
    from momakitchen.scene.configuration import SceneConfig

    config = SceneConfig(robots=("ur5e-x0.65", "ur10e-x0.86"), mount_height=(0.45, 1.15))
    assert config.robot_names == ("ur5e-x0.65", "ur10e-x0.86")
    with pytest.raises(MomaError, match="link scale"):
        SceneConfig(robots=("ur5e-x1.90",))
