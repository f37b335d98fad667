import math

import numpy as np
import pytest

from momakitchen.bullet import p
from momakitchen.scene.configuration import PART_SWEEP, part_sweep, sample_scene
from momakitchen.sim.config import TrialConfig
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


def _box_corners_xy(client: int, body: int, link: int) -> np.ndarray:
    """World xy (K, 2) of the corners of a link's collision boxes as PyBullet loaded them
    (its link AABBs are far too loose for compound shapes to be of use here)."""
    state = p.getLinkState(body, link, computeForwardKinematics=True, physicsClientId=client)
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    out = []
    for shape in p.getCollisionShapeData(body, link, physicsClientId=client):
        if shape[2] != p.GEOM_BOX:
            continue
        pos, orn = p.multiplyTransforms(state[0], state[1], shape[5], shape[6])
        rot = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3)
        corners = (signs * np.asarray(shape[3]) / 2) @ rot.T + np.asarray(pos)
        out.append(corners[:, :2])
    return np.concatenate(out) if out else np.zeros((0, 2))


def test_part_sweep_covers_the_moving_part_at_rest_and_opened():
    """The floor rectangle kept free of obstacles contains the whole door panel or drawer
    (as PyBullet sees it), closed and opened by PART_SWEEP: a pull-down door is as wide as
    the unit, not as its handle."""
    checked = 0
    for sid in (300, 301, 302):
        scene = sample_scene(sid)
        with World(scene.layout) as w:
            for cfg in scene.configurations:
                if cfg.target.articulation is None:
                    continue
                w.load_configuration(cfg)
                t = w.target
                assert t.joint_index is not None
                sweep = part_sweep(scene.layout.unit(cfg.target.uid), cfg.target.articulation)[0]
                lo, hi = sweep.min(0) - 1e-6, sweep.max(0) + 1e-6
                amount = PART_SWEEP[0] if t.joint_type == "revolute" else PART_SWEEP[1]
                amount = min(amount, t.limit) if t.limit > 0 else amount
                for opened in (0.0, amount):
                    angle = t.open_direction * opened
                    p.resetJointState(t.body_id, t.joint_index, angle, physicsClientId=w.client)
                    xy = _box_corners_xy(w.client, t.body_id, t.joint_index)
                    assert len(xy) > 0
                    assert np.all(xy >= lo) and np.all(xy <= hi), (sid, cfg.index, opened)
                checked += 1
    assert checked >= 5


@pytest.mark.parametrize("scene_id", [1000, 1001, 1003, 1005])
def test_every_part_opens_to_the_pull_goal_clear_of_other_units(scene_id):
    """Turned (or slid) kinematically to what the trials pull, no part penetrates another
    body: before fridges kept FRIDGE_GAP, their doors hit the worktop beside them at ~8°
    in scenes 1001-1005, and before side-hinged doors pivoted on their front face, the
    sink door of scene 1000 stopped against the next unit at 19.4°."""
    trial = TrialConfig()
    layout = sample_scene(scene_id).layout
    with World(layout) as w:
        c = w.client
        bodies = [info.body_id for info in w.bodies.values()]
        count = 0
        for unit in layout.furniture:
            info = w.bodies[unit.uid]
            for art in unit.model.articulations:
                joint = info.joints[art.joint]
                revolute = art.joint_type == "revolute"
                amount = math.radians(trial.pull_angle_deg) if revolute else trial.pull_distance
                amount = min(amount, art.limit)
                p.resetJointState(
                    info.body_id, joint, art.open_direction * amount, physicsClientId=c
                )
                for other in bodies:
                    if other == info.body_id:
                        continue
                    pts = p.getClosestPoints(
                        info.body_id, other, 0.0, linkIndexA=joint, physicsClientId=c
                    )
                    deepest = min((pt[8] for pt in pts), default=0.0)
                    assert deepest > -0.0005, (unit.uid, unit.category, art.joint, other, deepest)
                p.resetJointState(info.body_id, joint, 0.0, physicsClientId=c)
                count += 1
        assert count >= 5
