"""Fixtures: a PyBullet client, static or free boxes in it, and a tiny user robot (URDF +
YAML) written to a temporary folder."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

import pytest

from momakitchen.bullet import p


@pytest.fixture
def client() -> Iterator[int]:
    """A fresh DIRECT client, disconnected afterwards."""
    cid = p.connect(p.DIRECT)
    yield cid
    p.disconnect(cid)


@pytest.fixture
def box(client: int) -> Callable[..., int]:
    """``box(half_extents (3,), position (3,), mass=0.0) -> body id`` in ``client``."""

    def make(half: Sequence[float], pos: Sequence[float], mass: float = 0.0) -> int:
        col = p.createCollisionShape(p.GEOM_BOX, halfExtents=list(half), physicsClientId=client)
        return p.createMultiBody(mass, col, basePosition=list(pos), physicsClientId=client)

    return make


# A 4-DoF arm (yaw, pitch, pitch, roll) with link lengths 0.1 (base), 0.3, 0.25, 0.08
# and a two-finger gripper with prismatic fingers; TCP link "tool0" 0.1 m past the wrist.
TINY_ARM_URDF = """<?xml version="1.0"?>
<robot name="tiny">
  <link name="base"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01"
    ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 0.05"/><geometry><cylinder radius="0.05" length="0.1"/>
    </geometry></collision></link>
  <link name="l1"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01"
    ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="l2"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01"
    ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 0.15"/><geometry><cylinder radius="0.03" length="0.3"/>
    </geometry></collision></link>
  <link name="l3"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01"
    ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 0.125"/><geometry><cylinder radius="0.03" length="0.25"/>
    </geometry></collision></link>
  <link name="l4"><inertial><mass value="0.5"/><inertia ixx="0.01" iyy="0.01" izz="0.01"
    ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 0.04"/><geometry><box size="0.04 0.1 0.08"/></geometry>
    </collision></link>
  <link name="tool0"/>
  <link name="fl"><inertial><mass value="0.05"/><inertia ixx="0.001" iyy="0.001"
    izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0.006 0.02"/><geometry><box size="0.02 0.012 0.04"/></geometry>
    </collision></link>
  <link name="fr"><inertial><mass value="0.05"/><inertia ixx="0.001" iyy="0.001"
    izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 -0.006 0.02"/><geometry><box size="0.02 0.012 0.04"/></geometry>
    </collision></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="50" velocity="2"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
    <axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="50" velocity="2"/></joint>
  <joint name="j3" type="revolute"><parent link="l2"/><child link="l3"/>
    <origin xyz="0 0 0.3"/><axis xyz="0 1 0"/>
    <limit lower="-2.5" upper="2.5" effort="30" velocity="2"/></joint>
  <joint name="j4" type="revolute"><parent link="l3"/><child link="l4"/>
    <origin xyz="0 0 0.25"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="10" velocity="2"/></joint>
  <joint name="tool_joint" type="fixed"><parent link="l4"/><child link="tool0"/>
    <origin xyz="0 0 0.1"/></joint>
  <joint name="fl_joint" type="prismatic"><parent link="l4"/><child link="fl"/>
    <origin xyz="0 0 0.08"/><axis xyz="0 1 0"/>
    <limit lower="0" upper="0.04" effort="20" velocity="0.2"/></joint>
  <joint name="fr_joint" type="prismatic"><parent link="l4"/><child link="fr"/>
    <origin xyz="0 0 0.08"/><axis xyz="0 -1 0"/>
    <limit lower="0" upper="0.04" effort="20" velocity="0.2"/></joint>
</robot>
"""

# Farthest tool0 distance from the shoulder (joint 2): 0.3 + 0.25 + 0.1.
TINY_ARM_REACH = 0.65

TINY_YAML = """name: {name}
urdf: tiny.urdf
mount_height: 0.8
end_effector_link: tool0
end_effector: parallel_gripper
"""


@pytest.fixture
def tiny_robot_files(tmp_path: Path) -> tuple[Path, Path]:
    """``(urdf, yaml)`` paths of a valid user robot named ``tiny_user``."""
    urdf = tmp_path / "tiny.urdf"
    urdf.write_text(TINY_ARM_URDF)
    yaml_path = tmp_path / "tiny.yaml"
    yaml_path.write_text(TINY_YAML.format(name="tiny_user"))
    return urdf, yaml_path
