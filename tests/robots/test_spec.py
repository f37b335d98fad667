"""The robot registry (``robots/spec.py``): one entry per robot holding its numbers and its
model, the descriptor, and no simulator on import."""

from __future__ import annotations

import dataclasses
import subprocess
import sys

import pytest

from momakitchen.errors import MomaError
from momakitchen.registry import Registry
from momakitchen.robots import (
    DESCRIPTOR_NAMES,
    DESCRIPTOR_VERSION,
    ROBOTS,
    get_robot_spec,
    register_robot,
    robot_descriptor,
)
from momakitchen.robots.arms import BuiltArm, RobotModel, SuctionCup

NAMES = ["panda", "flexiv", "ur5e", "xarm6", "realman", "elephant"]


def test_every_robot_is_one_entry_with_its_model():
    assert isinstance(ROBOTS, Registry)
    assert ROBOTS.names()[:6] == tuple(NAMES)
    for name in NAMES:
        spec = get_robot_spec(name)
        assert spec is ROBOTS[name] and isinstance(spec.model, RobotModel)
        assert spec.model.tool_kind == spec.end_effector
        assert not spec.model.home or len(spec.model.home) == spec.dof
    assert {n: ROBOTS[n].end_effector for n in NAMES} == {
        "panda": "parallel_gripper",
        "flexiv": "parallel_gripper",
        "ur5e": "suction",
        "xarm6": "parallel_gripper",
        "realman": "parallel_gripper",
        "elephant": "parallel_gripper",
    }


def test_unknown_and_taken_names_are_moma_errors():
    with pytest.raises(MomaError, match="unknown robot 'nope'; known robots: panda, flexiv"):
        get_robot_spec("nope")
    with pytest.raises(MomaError, match="robot 'panda' is already registered"):
        register_robot(get_robot_spec("panda"))


def test_a_spec_must_agree_with_its_model():
    ur5e = get_robot_spec("ur5e")
    with pytest.raises(MomaError, match="end_effector 'parallel_gripper' but its model's tool"):
        dataclasses.replace(ur5e, name="bad", end_effector="parallel_gripper")
    with pytest.raises(MomaError, match="dof=7 but its arm has 6 joints"):
        dataclasses.replace(ur5e, name="bad", dof=7)
    assert isinstance(ur5e.model.arm, BuiltArm)
    short_home = RobotModel(ur5e.model.arm, SuctionCup(tcp_offset=0.1), home=(0.0,) * 5)
    with pytest.raises(MomaError, match="home needs 6 values, got 5"):
        dataclasses.replace(ur5e, name="bad", model=short_home)
    assert "bad" not in ROBOTS


def test_descriptor_is_reach_mount_height_dof_tool():
    assert DESCRIPTOR_VERSION == 1
    assert DESCRIPTOR_NAMES[:2] == ("reach_m", "mount_height_m")
    assert robot_descriptor(get_robot_spec("ur5e")) == (0.85, 1.03, 6 / 7, 1.0)
    assert robot_descriptor(get_robot_spec("xarm6")) == (0.70, 0.33, 6 / 7, 0.0)


@pytest.mark.parametrize("module", ["momakitchen.robots", "momakitchen.robots.spec"])
def test_the_registry_does_not_import_pybullet(module):
    code = f"import {module}, sys; {module}.ROBOTS['panda'].model; "
    code += "print('pybullet' in sys.modules)"
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    assert out.strip() == "False"
