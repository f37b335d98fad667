import numpy as np
import pytest

from momakitchen.bullet import p
from momakitchen.scene.configuration import sample_scene
from momakitchen.sim.validate import pull_test, settle_check
from momakitchen.sim.world import World


@pytest.fixture(scope="module")
def scene():
    return sample_scene(7)


@pytest.fixture(scope="module")
def world(scene):
    w = World(scene.layout)
    yield w
    w.close()


def test_configurations_spawn_without_penetration_and_stay_put(world, scene):
    for cfg in scene.configurations[:4]:
        world.load_configuration(cfg)
        assert world.penetrations() == []
        rep = settle_check(world, 1.0)
        assert rep.max_displacement < 0.02, rep
        assert rep.min_z > -0.01


def test_reloading_a_configuration_restores_the_world(world, scene):
    world.load_configuration(scene.configurations[1])
    ids = {
        u: p.getBasePositionAndOrientation(b.body_id, physicsClientId=world.client)
        for u, b in world.bodies.items()
        if b.kind == "rigid"
    }
    world.step(100)
    world.load_configuration(scene.configurations[0])
    world.load_configuration(scene.configurations[1])
    again = {
        u: p.getBasePositionAndOrientation(b.body_id, physicsClientId=world.client)
        for u, b in world.bodies.items()
        if b.kind == "rigid"
    }
    assert ids.keys() == again.keys()
    for uid in ids:
        assert np.allclose(ids[uid][0], again[uid][0], atol=1e-9)


def test_target_grasp_frame_is_at_the_anchor(world, scene):
    for cfg in scene.configurations:
        world.load_configuration(cfg)
        pos, normal, closing = world.grasp_in_world()
        assert np.allclose(pos, cfg.target.anchor, atol=2e-3)
        assert abs(np.linalg.norm(normal) - 1) < 1e-6
        assert abs(normal @ closing) < 1e-6


def test_every_articulated_part_opens_when_pulled(world, scene):
    world.load_configuration(scene.configurations[0])
    count = 0
    for unit in scene.layout.furniture:
        for i, art in enumerate(unit.model.articulations):
            opened = pull_test(world, unit.uid, i)
            assert opened > (0.02 if art.joint_type == "prismatic" else 0.035), (unit.uid, art)
            count += 1
    assert count >= 3


def test_two_worlds_coexist(scene):
    other = sample_scene(8)
    with World(scene.layout) as a, World(other.layout) as b:
        assert a.client != b.client
        a.load_configuration(scene.configurations[0])
        b.load_configuration(other.configurations[0])
        assert a.penetrations() == [] and b.penetrations() == []
