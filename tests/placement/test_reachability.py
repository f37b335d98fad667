"""The reachability map: it agrees with IK on poses it was not built from, it is cached
on disk and shared by mount heights, any registered robot has one, and an arm that
reaches nothing is a one-line error."""

from __future__ import annotations

import numpy as np
import pytest
from placement_helpers import COARSE, ik_agreement

from momakitchen.errors import MomaError
from momakitchen.placement import ReachabilityMap
from momakitchen.sim import reachability
from momakitchen.sim.sampling import SamplingConfig


@pytest.mark.slow
@pytest.mark.parametrize("robot", ["panda", "ur5e"])
def test_the_map_agrees_with_ik_on_held_out_poses(robot):
    agreement, reached = ik_agreement(robot, 600)
    # measured 2026-12-06: panda 0.975, ur5e 0.978 (docs/PLACEMENT.md)
    assert agreement >= 0.95
    assert 0.2 <= reached <= 0.8  # neither side of the question is trivial


def _user_panda_yaml(folder, name="pandauser", mount=0.9):
    """pybullet_data's Panda (its own hand) as a user robot."""
    import pybullet_data

    urdf = f"{pybullet_data.getDataPath()}/franka_panda/panda.urdf"
    path = folder / f"{name}.yaml"
    path.write_text(
        f"name: {name}\nurdf: {urdf}\nmount_height: {mount}\n"
        "end_effector_link: panda_grasptarget\nend_effector: parallel_gripper\nreach: 0.85\n"
    )
    return path


@pytest.fixture
def user_panda(tmp_path):
    from momakitchen.robots.user import register_user_robot, unregister_user_robot

    spec = register_user_robot(_user_panda_yaml(tmp_path))
    yield spec.name
    unregister_user_robot(spec.name)


def test_a_user_robot_has_a_map_that_agrees_with_ik_and_is_cached(user_panda, monkeypatch):
    from momakitchen.assets.cache import cache_dir

    agreement, reached = ik_agreement(user_panda, 120, COARSE)
    assert agreement >= 0.9 and 0.1 <= reached <= 0.9
    built = ReachabilityMap.for_robot(user_panda, None, COARSE)
    assert ReachabilityMap.for_robot(user_panda, None, COARSE) is built  # in memory
    files = list((cache_dir() / "reachability").glob(f"{user_panda}-*.npz"))
    assert len(files) == 1
    # From the disk cache, without sampling again: the same map to the bit.
    monkeypatch.setattr(reachability, "_SAMPLED", {})
    monkeypatch.setattr(reachability, "_MAPS", {})

    def no_sampling(*args, **kwargs):
        raise AssertionError("sampled again")

    monkeypatch.setattr("momakitchen.sim.sampling.sample_grid", no_sampling)
    loaded = ReachabilityMap.for_robot(user_panda, None, COARSE)
    assert loaded is not built
    np.testing.assert_array_equal(loaded.reachable, built.reachable)
    np.testing.assert_array_equal(loaded.distance, built.distance)
    assert (loaded.z_first, loaded.mount_height) == (built.z_first, built.mount_height)
    # Another mount height is the same arm raised: no sampling either.
    low = ReachabilityMap.for_robot(user_panda, 0.5, COARSE)
    assert low.z_first == pytest.approx(built.z_first - 0.4)
    above_floor = low.z_first + np.arange(low.reachable.shape[3]) * low.cell >= 0
    np.testing.assert_array_equal(
        low.reachable[..., above_floor], built.reachable[..., above_floor]
    )
    assert not low.reachable[..., ~above_floor].any()


def test_floor_map_scores_where_the_pose_is_reachable(user_panda):
    reach = ReachabilityMap.for_robot(user_panda, None, COARSE)
    target = np.array([1.0, 0.5, 0.9])
    xs, ys = np.meshgrid(np.linspace(-0.5, 2.5, 31), np.linspace(-1.0, 2.0, 31))
    floor = np.column_stack([xs.ravel(), ys.ravel()])
    for approach in (None, [0.0, 0.0, -1.0], [[1.0, 0.0, 0.0], [0.0, 0.0, -2.0]]):
        score = reach.floor_map(target, approach, floor)
        assert score.shape == (len(floor),) and ((score >= 0) & (score <= 1)).all()
        dirs = [None] if approach is None else list(np.reshape(approach, (-1, 3)))
        ok = np.any([reach.reachable_from(floor, target, a) for a in dirs], axis=0)
        np.testing.assert_array_equal(score > 0, ok)
        d = np.hypot(*(floor - target[:2]).T)
        assert ok.any() and not ok[d > 1.5].any()  # beyond any arm's reach from the base
    # The index prefers a dexterous arm: somewhere in between, not at the edge of reach.
    score = reach.floor_map(target, None, floor)
    d = np.hypot(*(floor - target[:2]).T)
    assert d[np.argmax(score)] < d[score > 0].max() - 0.1


def test_an_arm_that_reaches_no_approach_is_a_one_line_error(tmp_path):
    from momakitchen.robots.user import register_user_robot, unregister_user_robot

    # The tool points straight up whatever its joints do: no approach class is reachable.
    urdf = tmp_path / "upright.urdf"
    urdf.write_text(UPRIGHT_ARM)
    yaml_path = tmp_path / "upright.yaml"
    yaml_path.write_text(
        "name: upright\nurdf: upright.urdf\nmount_height: 0.8\nend_effector_link: tool0\n"
        "end_effector: suction\nreach: 0.5\n"
    )
    spec = register_user_robot(yaml_path)
    try:
        with pytest.raises(MomaError, match=r"'upright'.*empty reachability map") as info:
            ReachabilityMap.for_robot(spec.name, None, COARSE)
        assert "\n" not in str(info.value)
    finally:
        unregister_user_robot(spec.name)


def test_bad_input_names_the_value():
    with pytest.raises(MomaError, match="nosuchbot"):
        ReachabilityMap.for_robot("nosuchbot")
    with pytest.raises(MomaError, match=r"2\.5"):
        ReachabilityMap.for_robot("panda", 2.5)
    with pytest.raises(MomaError, match="cell"):
        SamplingConfig(cell=0.0)
    with pytest.raises(MomaError, match="pitches"):
        SamplingConfig(pitches=(10.0, 90.0))
    with pytest.raises(MomaError, match="psi_bins"):
        SamplingConfig(psi_bins=2)
    grid = np.zeros((3, 4, 5, 6), bool)
    with pytest.raises(MomaError, match=r"'nothing'.*empty reachability map"):
        ReachabilityMap("nothing", 1.0, 0.05, (0.0, 45.0, 90.0), np.zeros(2), 0.0, grid)
    grid[0, 0, 2, 3] = True
    with pytest.raises(MomaError, match="P = 2 pitch classes"):
        ReachabilityMap("x", 1.0, 0.05, (0.0, 90.0), np.zeros(2), 0.0, grid)
    one = ReachabilityMap("x", 1.0, 0.05, (0.0, 45.0, 90.0), np.zeros(2), 0.0, grid)
    with pytest.raises(MomaError, match="approach direction"):
        one.floor_map([0.0, 0.0, 0.5], [0.0, 0.0, 0.0], np.zeros((3, 2)))


# A 3-joint arm turning about vertical axes only, its tool pointing up: it reaches no
# pose that a grasp approaches sideways or from above.
UPRIGHT_ARM = """<?xml version="1.0"?>
<robot name="upright">
  <link name="base"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01"
    ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 0.05"/><geometry><cylinder radius="0.05" length="0.1"/>
    </geometry></collision></link>
  <link name="l1"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01"
    ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0.15 0 0"/><geometry><box size="0.3 0.04 0.04"/></geometry>
    </collision></link>
  <link name="l2"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01"
    ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0.1 0 0"/><geometry><box size="0.2 0.04 0.04"/></geometry>
    </collision></link>
  <link name="l3"><inertial><mass value="0.5"/><inertia ixx="0.01" iyy="0.01" izz="0.01"
    ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 0.04"/><geometry><cylinder radius="0.02" length="0.08"/>
    </geometry></collision></link>
  <link name="tool0"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="50" velocity="2"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
    <origin xyz="0.3 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-2.5" upper="2.5" effort="50" velocity="2"/></joint>
  <joint name="j3" type="revolute"><parent link="l2"/><child link="l3"/>
    <origin xyz="0.2 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="10" velocity="2"/></joint>
  <joint name="tool_joint" type="fixed"><parent link="l3"/><child link="tool0"/>
    <origin xyz="0 0 0.1"/></joint>
</robot>
"""
