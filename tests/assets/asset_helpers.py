"""Helpers of the asset tests: envelopes, loading, AABBs, joint conventions."""

from __future__ import annotations

import numpy as np
import pybullet as pb

from momakitchen.assets import Envelope, get_category
from momakitchen.assets.cache import cached_urdf

# Envelopes like those the layout grants (width, counter depth, counter height; fridge: max
# height; microwave: free countertop).
ENVELOPES = {
    "cabinet": Envelope(0.6, 0.6, 0.9),
    "sink": Envelope(0.8, 0.62, 0.88),
    "dishwasher": Envelope(0.6, 0.6, 0.9),
    "oven": Envelope(0.6, 0.64, 0.92),
    "fridge": Envelope(0.8, 0.7, 1.9),
    "microwave": Envelope(0.58, 0.42, 0.4),
}


def envelope_for(name: str, rng: np.random.Generator | None = None) -> Envelope | None:
    """The category's envelope, randomly varied when ``rng`` is given."""
    kind = get_category(name).kind
    if kind not in ("furniture", "appliance"):
        return None
    env = ENVELOPES[name]
    if rng is None:
        return env
    lo, hi = getattr(get_category(name), "width_range", (env.width, env.width))
    if name == "microwave":
        return Envelope(
            round(float(rng.uniform(0.45, 0.6)), 4), round(float(rng.uniform(0.33, 0.45)), 4), 0.4
        )
    if name == "fridge":
        return Envelope(
            round(float(rng.uniform(0.6, 0.9)), 4),
            round(float(rng.uniform(0.62, 0.78)), 4),
            round(float(rng.uniform(1.75, 2.0)), 4),
        )
    return Envelope(
        round(float(rng.uniform(max(lo, 0.45), min(hi, 1.0))), 4),
        round(float(rng.uniform(0.56, 0.66)), 4),
        round(float(rng.uniform(0.86, 0.94)), 4),
    )


def load(model, client: int, fixed: bool, pos=(0.0, 0.0, 0.0), inertia: bool = True) -> int:
    """Load as the world builder does (inertia from the file). ``inertia=False`` lets PyBullet
    keep link-aligned inertial frames: then ``getAABB`` is not inflated by the rotation of the
    principal axes, which is what a geometric size check needs."""
    path = model.path or str(cached_urdf(model.urdf, model.category))
    flags = pb.URDF_USE_INERTIA_FROM_FILE if inertia else 0
    return pb.loadURDF(
        path,
        basePosition=pos,
        useFixedBase=fixed,
        globalScaling=model.scale,
        flags=flags,
        physicsClientId=client,
    )


def body_aabb(body: int, client: int) -> tuple[np.ndarray, np.ndarray]:
    n = pb.getNumJoints(body, physicsClientId=client)
    boxes = [
        pb.getAABB(body, k, physicsClientId=client)
        for k in range(-1, n)
        if pb.getCollisionShapeData(body, k, physicsClientId=client)
    ]
    return np.min([b[0] for b in boxes], axis=0), np.max([b[1] for b in boxes], axis=0)


def joint_friction_motors(body: int, client: int) -> None:
    """The convention of docs/ASSETS.md: the URDF joint friction becomes the force of
    PyBullet's default velocity motor (dry friction)."""
    for j in range(pb.getNumJoints(body, physicsClientId=client)):
        info = pb.getJointInfo(body, j, physicsClientId=client)
        if info[2] in (pb.JOINT_REVOLUTE, pb.JOINT_PRISMATIC):
            pb.setJointMotorControl2(
                body,
                j,
                pb.VELOCITY_CONTROL,
                targetVelocity=0,
                force=float(info[7]),
                physicsClientId=client,
            )


def joint_index(body: int, client: int) -> dict[str, int]:
    return {
        pb.getJointInfo(body, j, physicsClientId=client)[1].decode(): j
        for j in range(pb.getNumJoints(body, physicsClientId=client))
    }


def link_index(body: int, client: int) -> dict[str, int]:
    out = {pb.getBodyInfo(body, physicsClientId=client)[0].decode(): -1}
    for j in range(pb.getNumJoints(body, physicsClientId=client)):
        out[pb.getJointInfo(body, j, physicsClientId=client)[12].decode()] = j
    return out
