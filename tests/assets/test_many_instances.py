"""Many instances per category (slow): every one builds, loads, matches its size, stands
still, and distinct draws stay distinct."""

from __future__ import annotations

import numpy as np
import pybullet as pb
import pytest
from asset_helpers import body_aabb, envelope_for, joint_friction_motors, load

from momakitchen.assets import CATEGORIES, get_category

pytestmark = pytest.mark.slow


@pytest.mark.parametrize("name", sorted(CATEGORIES))
def test_two_hundred_instances_load_match_and_rest(name, client):
    pb.setGravity(0, 0, -9.81, physicsClientId=client)
    floor = pb.createCollisionShape(pb.GEOM_PLANE, physicsClientId=client)
    pb.createMultiBody(0, floor, physicsClientId=client)
    cat = get_category(name)
    rng = np.random.default_rng(2024)
    texts = set()
    for _ in range(200):
        model = cat.build(cat.sample(rng, envelope_for(name, rng)))
        texts.add(model.urdf)
        body = load(model, client, fixed=True, inertia=False)
        lo, hi = body_aabb(body, client)
        assert np.all(np.abs((hi - lo) - np.asarray(model.size)) <= 0.0065), name
        pb.removeBody(body, physicsClientId=client)
    assert len(texts) == 200
    # a free-standing sample of them rests still on the floor for 1 s
    rng = np.random.default_rng(7)
    for _ in range(20):
        model = cat.build(cat.sample(rng, envelope_for(name, rng)))
        body = load(model, client, fixed=False, pos=(0.0, 0.0, 0.0005))
        joint_friction_motors(body, client)
        p0, _ = pb.getBasePositionAndOrientation(body, physicsClientId=client)
        for _ in range(240):
            pb.stepSimulation(physicsClientId=client)
        p1, _ = pb.getBasePositionAndOrientation(body, physicsClientId=client)
        assert np.linalg.norm(np.subtract(p1, p0)) < 0.01, name
        pb.removeBody(body, physicsClientId=client)
