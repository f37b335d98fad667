"""The robot registry (``robots/spec.py``): one entry per robot holding its numbers and its
model, the descriptor, and no simulator on import."""

from __future__ import annotations

import dataclasses
import itertools
import subprocess
import sys

import numpy as np
import pytest

from momakitchen.errors import MomaError
from momakitchen.registry import Registry
from momakitchen.robots import (
    DESCRIPTOR_NAMES,
    DESCRIPTOR_VERSION,
    ROBOTS,
    get_robot_spec,
    register_robot,
)
from momakitchen.robots.arms import RobotModel, UrdfArm
from momakitchen.robots.descriptor import robot_descriptor, upgrade_descriptor
from momakitchen.robots.spec import DESCRIPTOR_DIM, DESCRIPTOR_LAYOUTS, descriptor_dim
from momakitchen.robots.user import register_user_robot, unregister_user_robot

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
    assert isinstance(ur5e.model.arm, UrdfArm)
    short_home = RobotModel(ur5e.model.arm, ur5e.model.end_effector, home=(0.0,) * 5)
    with pytest.raises(MomaError, match="home needs 6 values, got 5"):
        dataclasses.replace(ur5e, name="bad", model=short_home)
    assert "bad" not in ROBOTS


def test_the_built_ins_are_registered_from_their_shipped_files():
    from momakitchen.robots.spec import BUILT_IN_ROBOTS
    from momakitchen.robots.user import SHIPPED, user_robot_file

    assert ROBOTS.names()[: len(BUILT_IN_ROBOTS)] == BUILT_IN_ROBOTS
    for name in BUILT_IN_ROBOTS:
        spec = get_robot_spec(name)
        assert spec.model.arm.urdf == SHIPPED / f"{name}.urdf"
        assert spec.model.source  # where the figures come from, from the YAML
        assert user_robot_file(name) is None  # a built-in, not a user robot


def test_descriptor_is_reach_mount_height_dof_tool_grip_shoulder(tmp_path):
    assert DESCRIPTOR_VERSION == 3
    assert DESCRIPTOR_NAMES[:2] == ("reach_m", "mount_height_m")
    ur5e = robot_descriptor(get_robot_spec("ur5e"))
    assert ur5e[:5] == (0.85, 1.03, 6 / 7, 1.0, 0.0)
    # UR's DH d1: the shoulder 0.1625 m above the mount, on joint 1's axis.
    assert ur5e[5:] == pytest.approx((1.03 + 0.1625, 0.0), abs=1e-9)
    assert robot_descriptor(get_robot_spec("xarm6"))[:5] == (0.70, 0.33, 6 / 7, 0.0, 0.4)
    assert robot_descriptor(get_robot_spec("panda"))[4] == 0.7
    # The descriptor twins of version 2 (docs/ROBOTS.md): apart in version 3.
    elephant = robot_descriptor(get_robot_spec("elephant"))
    yaml = tmp_path / "twin.yaml"
    yaml.write_text("name: twin\nlike: realman\nlink_scale: 0.7\nfinger_force: 40\n")
    twin = robot_descriptor(register_user_robot(yaml))
    unregister_user_robot("twin")
    assert elephant[:5] == pytest.approx(twin[:5], abs=0.005)
    assert elephant[5] - twin[5] == pytest.approx(0.229 - 0.7 * 0.172, abs=0.001)
    assert (elephant[6], twin[6]) == pytest.approx((0.0, 0.7 * 0.86), abs=0.001)


def test_each_descriptor_layout_extends_the_one_before():
    versions = sorted(DESCRIPTOR_LAYOUTS)
    assert versions == list(range(1, DESCRIPTOR_VERSION + 1))
    for old, new in itertools.pairwise(versions):
        assert DESCRIPTOR_LAYOUTS[new][: len(DESCRIPTOR_LAYOUTS[old])] == DESCRIPTOR_LAYOUTS[old]
    assert [descriptor_dim(v) for v in versions] == [4, 5, 7]
    for bad in (0, 4, True, "1", None):
        with pytest.raises(MomaError, match=r"descriptor version .* is unknown"):
            descriptor_dim(bad)


def test_a_version_1_descriptor_gains_its_robots_finger_force():
    old = np.asarray([0.63, 0.9, 6 / 7, 0.0], np.float32)  # a drawn mount stays as stored
    new = upgrade_descriptor(old, 1, "elephant")
    assert new.dtype == np.float32 and new.shape == (DESCRIPTOR_DIM,)
    assert np.array_equal(new[:4], old) and new[4] == np.float32(0.4)
    # The shoulder stands above the stored (drawn) mount, not the robot's own.
    assert new[5] == np.float32(0.9 + 0.22934) and new[6] == 0.0
    assert upgrade_descriptor(new, DESCRIPTOR_VERSION, "elephant") is new
    assert upgrade_descriptor(old, 1, "ur5e")[4] == 0.0  # suction
    with pytest.raises(MomaError, match="version-1 robot descriptor has 4 values"):
        upgrade_descriptor(new, 1, "elephant")
    with pytest.raises(MomaError, match="unknown robot 'nobody'"):
        upgrade_descriptor(old, 1, "nobody")


@pytest.mark.parametrize("module", ["momakitchen.robots", "momakitchen.robots.spec"])
def test_the_registry_does_not_import_pybullet(module):
    code = f"import {module}, sys; {module}.ROBOTS['panda'].model; "
    code += "print('pybullet' in sys.modules)"
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    assert out.strip() == "False"


def test_more_arms_are_registered_but_not_generated_by_default():
    from momakitchen.robots.spec import DEFAULT_ROBOTS

    assert DEFAULT_ROBOTS == tuple(NAMES)
    ur10e, gen3 = get_robot_spec("ur10e"), get_robot_spec("gen3")
    assert (ur10e.reach, ur10e.mount_height, ur10e.dof) == (1.30, 0.80, 6)
    assert (gen3.reach, gen3.mount_height, gen3.dof) == (0.902, 0.60, 7)
    # They widen the reach range beyond the paper's six (0.63-0.90 m).
    assert max(get_robot_spec(n).reach for n in NAMES) < gen3.reach < ur10e.reach
    assert not {"ur10e", "gen3"} & set(DEFAULT_ROBOTS)


def test_mount_heights_are_checked_against_the_documented_range():
    from momakitchen.robots.spec import MOUNT_RANGE

    assert MOUNT_RANGE == (0.30, 1.30)
    panda = get_robot_spec("panda")
    for bad, message in [
        (dict(mount_height=1.31), r"mount_height must be in \[0.3, 1.3\] m, got 1.31"),
        (dict(mount_height=0.2), r"got 0.2"),
        (dict(mount_range=(0.6, 1.4)), r"got 1.4 \(in the range \[0.6, 1.4\]\)"),
        (dict(mount_range=(1.0, 0.6)), r"lo <= hi, got \[1.0, 0.6\]"),
        (dict(mount_range=(0.6, 0.9)), r"mount_height 1.03 lies outside its mount_range"),
    ]:
        with pytest.raises(MomaError, match=message):
            dataclasses.replace(panda, name="bad", **bad)
    ranged = dataclasses.replace(panda, name="ranged", mount_range=(0.6, 1.3))
    assert ranged.mount_heights == (0.6, 1.3) and panda.mount_heights == (1.03, 1.03)


def test_descriptor_takes_a_configurations_mount_height():
    ur5e = get_robot_spec("ur5e")
    assert robot_descriptor(ur5e, None) == robot_descriptor(ur5e)
    assert robot_descriptor(ur5e, 0.62) == pytest.approx(
        (0.85, 0.62, 6 / 7, 1.0, 0.0, 0.62 + 0.1625, 0.0), abs=1e-12
    )
