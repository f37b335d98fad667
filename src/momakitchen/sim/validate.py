"""Physical sanity checks of built worlds: spawn interpenetration, stability, articulation.

Used by the tests and by ``benchmarks/validate_scenes.py`` over many scene ids.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from momakitchen.bullet import p
from momakitchen.errors import MomaError
from momakitchen.sim.world import World


@dataclass(frozen=True)
class StabilityReport:
    """Largest displacement (m) of any free body after ``seconds`` of physics, and the
    lowest z reached by a body's base (a body that fell through the floor goes negative)."""

    max_displacement: float
    min_z: float
    worst_uid: str


def settle_check(world: World, seconds: float = 1.0) -> StabilityReport:
    """Simulate ``seconds`` and measure how far the free bodies (objects, obstacles) moved.

    The world state is restored afterwards.
    """
    c = world.client
    free = [b for b in world.bodies.values() if b.kind in ("rigid", "obstacle")]
    start = {
        b.uid: np.array(p.getBasePositionAndOrientation(b.body_id, physicsClientId=c)[0])
        for b in free
    }
    state = world.save_state()
    world.step(round(seconds * 240))
    worst, worst_uid, min_z = 0.0, "", np.inf
    for b in free:
        pos = np.array(p.getBasePositionAndOrientation(b.body_id, physicsClientId=c)[0])
        d = float(np.linalg.norm(pos - start[b.uid]))
        min_z = min(min_z, float(pos[2]))
        if d > worst:
            worst, worst_uid = d, b.uid
    world.restore_state(state)
    p.removeState(state, physicsClientId=c)
    return StabilityReport(worst, min_z if free else 0.0, worst_uid)


def opening_direction(
    world: World, body_id: int, joint: int, handle: np.ndarray, open_direction: int
) -> np.ndarray:
    """Unit world direction in which the handle point moves when the joint opens.

    From the joint axis (given in the child link's URDF frame, whose origin is the joint):
    ``axis x (handle - origin)`` for a revolute joint, the axis itself for a prismatic one.
    """
    c = world.client
    info = p.getJointInfo(body_id, joint, physicsClientId=c)
    origin, rot = world.link_pose(body_id, joint)
    axis = rot @ np.asarray(info[13], float)
    move = np.cross(axis, handle - origin) if info[2] == p.JOINT_REVOLUTE else axis
    move = move * open_direction
    return move / max(float(np.linalg.norm(move)), 1e-12)


def pull_test(
    world: World, uid: str, articulation: int, force: float = 40.0, seconds: float = 0.6
) -> float:
    """Pull the handle of ``uid``'s part ``articulation`` with ``force`` newtons along its
    opening direction for ``seconds``; return how far the joint opened (rad or m, signed so
    that positive = opening). The world state is restored afterwards."""
    c = world.client
    info = world.bodies[uid]
    model = info.model
    if model is None:
        raise MomaError(f"{uid!r} is room structure, not an articulated asset")
    art = model.articulations[articulation]
    joint, link = info.joints[art.joint], info.links[art.handle.link]
    state = world.save_state()
    q0 = p.getJointState(info.body_id, joint, physicsClientId=c)[0]
    for _ in range(round(seconds * 240)):
        pos, rot = world.link_pose(info.body_id, link)
        handle = rot @ np.asarray(art.handle.position) + pos
        direction = opening_direction(world, info.body_id, joint, handle, art.open_direction)
        p.applyExternalForce(
            info.body_id,
            link,
            (force * direction).tolist(),
            handle.tolist(),
            p.WORLD_FRAME,
            physicsClientId=c,
        )
        world.step()
    q1 = p.getJointState(info.body_id, joint, physicsClientId=c)[0]
    world.restore_state(state)
    p.removeState(state, physicsClientId=c)
    return float((q1 - q0) * art.open_direction)
