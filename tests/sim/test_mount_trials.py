"""Trials of a configuration with a drawn mount height: the trial robot stands at it, the
labels record it."""

from __future__ import annotations

import dataclasses

import pytest

from momakitchen.scene.configuration import sample_scene
from momakitchen.sim.labels import label_configuration
from momakitchen.sim.trials import TrialRunner
from momakitchen.sim.world import World


@pytest.fixture(scope="module")
def scene():
    return sample_scene(12)


def test_the_trial_robot_stands_at_the_configurations_mount_height(scene):
    own = scene.configurations[0]
    assert own.robot == "panda" and own.mount_height is None
    low = dataclasses.replace(own, mount_height=0.74)
    with World(scene.layout) as world:
        world.load_configuration(own)
        runner = TrialRunner(world, own.robot)
        assert runner.robot.mount_height == 1.03
        runner.close()
        labels = label_configuration(world, low, grid_spacing=0.4)
        assert labels.mount_height == 0.74 and labels.summary()["mount_height"] == 0.74
        world.load_configuration(low)
        runner = TrialRunner(world, low.robot)
        try:
            assert runner.robot.mount_height == 0.74
            first = runner.robot.arm_joints[0]
            pillar_top = runner.robot.link_pose(runner.robot._parent[first])[0][2]
            assert pillar_top == pytest.approx(0.74, abs=1e-6)
            # Another robot than the configuration's stands at its own height.
            other = TrialRunner(world, "ur5e")
            assert other.robot.mount_height == 1.03
            other.close()
        finally:
            runner.close()
