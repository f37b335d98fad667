"""Mount heights: any arm at any height of MOUNT_RANGE, the built-in robots unchanged at
their own, caches shared or kept per height as they should be."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

from momakitchen.errors import MomaError
from momakitchen.robots import collisions, ik, reach
from momakitchen.robots.arms import PYBULLET_DATA
from momakitchen.robots.robot import Robot
from momakitchen.robots.spec import get_robot_spec
from momakitchen.robots.urdf import build_urdf

# sha256 (first 16 hex digits) of the built-ins' URDFs at their own mount height, as built
# from their shipped files. Before the built-ins were loaded from files (their arms built
# from joint tables in code), the text differed in element order only: the bodies PyBullet
# loads from either, joint by joint and link by link (joint frames, axes and limits, masses,
# inertias, collision shapes) and their forward kinematics, are the same to the bit
# (docs/ROBOTS.md, "One loader for every robot").
BUILT_IN_URDFS = {
    "panda": "d554dc214be30b6b",
    "flexiv": "e2e04787d51e01d1",
    "ur5e": "578e6789e92f8848",
    "xarm6": "65c691603adfe8a1",
    "realman": "241dd0c30ac5cc89",
    "elephant": "4a19e0776d566813",
    "ur10e": "5345d9e651f419e1",
    "gen3": "dbb59e12d0c0a9dc",
}


@pytest.mark.parametrize("name", sorted(BUILT_IN_URDFS))
def test_urdf_at_the_robots_own_height_is_unchanged(name):
    spec = get_robot_spec(name)
    text = build_urdf(spec)
    assert text == build_urdf(spec, None) == build_urdf(spec, spec.mount_height)
    digest = hashlib.sha256(text.replace(str(PYBULLET_DATA), "PYBULLET_DATA").encode())
    assert digest.hexdigest()[:16] == BUILT_IN_URDFS[name]


@pytest.mark.parametrize("name", ["panda", "xarm6", "ur10e"])
def test_another_height_changes_only_the_pillar_and_the_mount_joint(name):
    spec = get_robot_spec(name)

    def after_base(text: str) -> list[str]:
        lines = text.splitlines()
        start = next(i for i, line in enumerate(lines) if 'name="mobile_base"' in line)
        return lines[lines.index("  </link>", start) + 1 :]

    own, other = after_base(build_urdf(spec)), after_base(build_urdf(spec, 0.62))
    # Everything after the base link (arm, tool) is the same text but the mount joint's
    # origin.
    assert len(own) == len(other)
    changed = [b for a, b in zip(own, other, strict=True) if a != b]
    assert len(changed) == 1 and f"0 {0.62:.9g}" in changed[0] and "origin" in changed[0]
    base = build_urdf(spec, 0.62).split('name="mobile_base"')[1].split("</link>")[0]
    assert f'length="{0.62 - 0.33:.9g}"' in base  # the pillar, from the box up to 0.62 m


@pytest.mark.parametrize("name", ["panda", "gen3", "elephant"])
def test_arm_stands_at_the_mount_height_and_moves_rigidly_with_it(client, name):
    spec = get_robot_spec(name)
    own = Robot(client, name)
    q = own.home.copy()
    tcp_own = own.tcp_pose(q)[0]
    for height in (0.3, 0.75, 1.3):
        robot = Robot(client, name, mount_height=height)
        try:
            assert robot.mount_height == height and robot.mount_shift == pytest.approx(
                height - spec.mount_height
            )
            first = robot.arm_joints[0]
            assert robot.link_pose(robot._parent[first])[0][2] == pytest.approx(height, abs=1e-6)
            shift = np.array([0.0, 0.0, height - spec.mount_height])
            assert np.allclose(robot.tcp_pose(q)[0], tcp_own + shift, atol=1e-6)
            # IK from the height-independent seed library reaches a point below the shoulder.
            goal = robot.shoulder_position() + np.array([0.45, 0.1, -0.25])
            assert robot.solve_ik(goal).success, (name, height)
        finally:
            robot.remove()
    own.remove()


def test_workspace_and_seeds_are_shared_self_pairs_are_per_height(client):
    Robot(client, "realman").remove()
    Robot(client, "realman", mount_height=0.5).remove()
    assert "realman" in reach.WORKSPACE_CACHE and "realman" in ik.SEED_LIBRARY
    assert "realman@0.5" not in reach.WORKSPACE_CACHE
    assert {"realman", "realman@0.5"} <= set(collisions.SELF_PAIRS_CACHE)
    # At its own height the robot is the same robot (one cache entry, no variant).
    robot = Robot(client, "realman", mount_height=get_robot_spec("realman").mount_height)
    assert robot.cache_key == "realman" and robot.mount_shift == 0.0
    robot.remove()


@pytest.mark.parametrize("height", [0.29, 1.31, float("nan")])
def test_a_mount_outside_the_range_is_one_line_naming_it(client, height):
    with pytest.raises(MomaError, match=r"robot 'panda': mount_height must be in \[0.3, 1.3\]"):
        Robot(client, "panda", mount_height=height)
    with pytest.raises(MomaError, match=f"got {height!r}"):
        build_urdf(get_robot_spec("panda"), height)
