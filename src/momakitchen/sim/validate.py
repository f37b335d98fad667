"""Physical sanity checks of built worlds: spawn interpenetration, stability, articulation.

Used by the tests and by ``benchmarks/validate_scenes.py`` over many scene ids.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pybullet as p

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
    start = {b.uid: np.array(p.getBasePositionAndOrientation(b.body_id, physicsClientId=c)[0])
             for b in free}
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


def opening_direction(world: World, body_id: int, joint: int, link: int,
                      handle: np.ndarray, open_direction: int) -> np.ndarray:
    """Unit world direction in which the handle point moves when the joint opens.

    Computed from the link Jacobian at the current joint positions, so it can be evaluated
    every physics step without disturbing the simulation.
    """
    c = world.client
    movable = [j for j in range(p.getNumJoints(body_id, physicsClientId=c))
               if p.getJointInfo(body_id, j, physicsClientId=c)[2] != p.JOINT_FIXED]
    q = [p.getJointState(body_id, j, physicsClientId=c)[0] for j in movable]
    state = p.getLinkState(body_id, link, computeForwardKinematics=True, physicsClientId=c)
    com_rot = np.array(p.getMatrixFromQuaternion(state[1])).reshape(3, 3)
    local = com_rot.T @ (handle - np.array(state[0]))
    zeros = [0.0] * len(q)
    lin, _ = p.calculateJacobian(body_id, link, local.tolist(), q, zeros, zeros,
                                 physicsClientId=c)
    move = np.array(lin)[:, movable.index(joint)] * open_direction
    return move / max(float(np.linalg.norm(move)), 1e-12)


def pull_test(world: World, uid: str, articulation: int, force: float = 40.0,
              seconds: float = 0.6) -> float:
    """Pull the handle of ``uid``'s part ``articulation`` with ``force`` newtons along its
    opening direction for ``seconds``; return how far the joint opened (rad or m, signed so
    that positive = opening). The world state is restored afterwards."""
    c = world.client
    info = world.bodies[uid]
    art = info.model.articulations[articulation]
    joint, link = info.joints[art.joint], info.links[art.handle.link]
    state = world.save_state()
    q0 = p.getJointState(info.body_id, joint, physicsClientId=c)[0]
    for _ in range(round(seconds * 240)):
        pos, rot = world.link_pose(info.body_id, link)
        handle = rot @ np.asarray(art.handle.position) + pos
        direction = opening_direction(world, info.body_id, joint, link, handle,
                                      art.open_direction)
        p.applyExternalForce(info.body_id, link, (force * direction).tolist(), handle.tolist(),
                             p.WORLD_FRAME, physicsClientId=c)
        world.step()
    q1 = p.getJointState(info.body_id, joint, physicsClientId=c)[0]
    world.restore_state(state)
    p.removeState(state, physicsClientId=c)
    return float((q1 - q0) * art.open_direction)
