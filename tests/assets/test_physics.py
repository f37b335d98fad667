"""Assets in physics: stable at rest, and every articulated part opens when its handle is
pulled along its normal."""

from __future__ import annotations

import dataclasses

import numpy as np
import pybullet as pb
import pytest
from asset_helpers import envelope_for, joint_friction_motors, joint_index, link_index, load

from momakitchen.assets import categories_of_kind, get_category

DT = 1.0 / 240.0
ARTICULATED = ["cabinet", "sink", "dishwasher", "oven", "fridge", "microwave"]


def _instances(name: str, n: int, seed: int):
    rng = np.random.default_rng(seed)
    cat = get_category(name)
    return [cat.build(cat.sample(rng, envelope_for(name, rng))) for _ in range(n)]


def _floor(client: int) -> int:
    shape = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[40, 5, 0.05], physicsClientId=client)
    return pb.createMultiBody(0, shape, basePosition=[35, 0, -0.05], physicsClientId=client)


@pytest.mark.parametrize("kind", ["furniture", "appliance", "obstacle", "rigid"])
def test_assets_rest_still_for_one_second(kind, client):
    """Furniture, appliances and obstacles stand free on the floor; rigid targets on a table
    top (a fixed slab at 0.9 m). After 1 s nothing has fallen, flown or slid."""
    pb.setGravity(0, 0, -9.81, physicsClientId=client)
    _floor(client)
    top = 0.0
    if kind in ("rigid", "appliance"):
        top = 0.9
        slab = pb.createCollisionShape(
            pb.GEOM_BOX, halfExtents=[40, 3, 0.02], physicsClientId=client
        )
        pb.createMultiBody(0, slab, basePosition=[35, 0, top - 0.02], physicsClientId=client)
    bodies = []
    x = 0.0
    for name in categories_of_kind(kind):
        for model in _instances(name, 4, seed=11):
            pos = (x + model.size[0] / 2, 0.0, top + 0.0005)
            body = load(model, client, fixed=False, pos=pos)
            joint_friction_motors(body, client)
            bodies.append((name, body, np.asarray(pos)))
            x += model.size[0] + 0.3
    start = {b: pb.getBasePositionAndOrientation(b, physicsClientId=client) for _, b, _ in bodies}
    for _ in range(240):
        pb.stepSimulation(physicsClientId=client)
    for name, body, _pos in bodies:
        p0, q0 = start[body]
        p1, q1 = pb.getBasePositionAndOrientation(body, physicsClientId=client)
        moved = np.linalg.norm(np.subtract(p1, p0))
        turned = 2 * np.degrees(np.arccos(min(1.0, abs(float(np.dot(q0, q1))))))
        assert moved < 0.01, (name, moved)
        assert turned < 2.0, (name, turned)
        # closed parts stay closed
        for j in range(pb.getNumJoints(body, physicsClientId=client)):
            if pb.getJointInfo(body, j, physicsClientId=client)[2] != pb.JOINT_FIXED:
                assert abs(pb.getJointState(body, j, physicsClientId=client)[0]) < 0.05, name


def pull_open(model, client: int, force: float, seconds: float = 0.5) -> dict[str, float]:
    """Pull each handle along its (moving) normal with the carcass fixed; joint travel."""
    out = {}
    for art in model.articulations:
        body = load(model, client, fixed=True)
        joint_friction_motors(body, client)
        j = joint_index(body, client)[art.joint]
        k = link_index(body, client)[art.handle.link]
        for _ in range(int(seconds / DT)):
            st = pb.getLinkState(body, k, computeForwardKinematics=True, physicsClientId=client)
            rot = np.asarray(pb.getMatrixFromQuaternion(st[5])).reshape(3, 3)
            point = np.asarray(st[4]) + rot @ np.asarray(art.handle.position)
            direction = rot @ np.asarray(art.handle.normal)
            pb.applyExternalForce(
                body,
                k,
                (force * direction).tolist(),
                point.tolist(),
                pb.WORLD_FRAME,
                physicsClientId=client,
            )
            pb.stepSimulation(physicsClientId=client)
        q = pb.getJointState(body, j, physicsClientId=client)[0]
        out[art.joint] = q * art.open_direction
        pb.removeBody(body, physicsClientId=client)
    return out


# Pull forces (N): a firm one-hand pull; the faucet lever is light.
FORCE = {"lever": 5.0, "door": 30.0, "drawer": 30.0}


@pytest.mark.parametrize("name", ARTICULATED)
def test_every_handle_pull_opens_its_joint(name, client):
    pb.setGravity(0, 0, -9.81, physicsClientId=client)
    for model in _instances(name, 3, seed=5):
        for art in model.articulations:
            one = dataclasses.replace(model, articulations=(art,))
            travel = pull_open(one, client, FORCE[art.part])[art.joint]
            need = np.radians(20) if art.joint_type == "revolute" else 0.10
            assert travel >= min(need, 0.9 * art.limit), (name, art.joint, travel)
