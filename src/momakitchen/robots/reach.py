"""Reach of a :class:`~momakitchen.robots.robot.Robot`: workspace spheres and the cheap
reachability pre-check.

The workspace radii (flange and TCP distance from the shoulder) are measured once per
robot and process (:data:`WORKSPACE_CACHE`). The spheres are centred where the shoulder
projects onto joint 1's axis (a point fixed on the base) and grown by the shoulder's
distance from that axis, so the pre-check never rejects a reachable pose.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from momakitchen.bullet import p
from momakitchen.robots.body import RobotBody

# A few thousand random configurations give the workspace radius to within ~1 %.
WORKSPACE_SAMPLES = 1500
# Per process and robot name: (flange reach, TCP reach) in metres.
WORKSPACE_CACHE: dict[str, tuple[float, float]] = {}


def workspace(robot: RobotBody) -> tuple[float, float]:
    """``(max flange distance, max TCP distance)`` from the shoulder, metres.

    Measured over random joint configurations within the limits (cached per robot).
    """
    if robot.name not in WORKSPACE_CACHE:
        WORKSPACE_CACHE[robot.name] = measure_workspace(robot, WORKSPACE_SAMPLES)
    return WORKSPACE_CACHE[robot.name]


def could_reach(
    robot: RobotBody,
    position: ArrayLike,
    orientation: ArrayLike | None = None,
    margin: float = 0.0,
) -> bool:
    """Cheap necessary condition for a TCP pose to be reachable.

    Without ``orientation``: the TCP lies within the TCP workspace sphere. With it, also
    the tighter test: the flange, rigidly offset from the TCP, lies within the flange
    workspace sphere. The spheres are centred on joint 1's axis at shoulder height and
    grown by the shoulder's offset from that axis (the shoulder turns with joint 1).
    """
    rot = None
    if orientation is not None:
        quat = np.asarray(orientation, float).tolist()
        rot = np.array(p.getMatrixFromQuaternion(quat)).reshape(3, 3)
    return within_reach(robot, np.asarray(position, float), rot, margin)


def within_reach(
    robot: RobotBody, tcp_pos: np.ndarray, tcp_rot: np.ndarray | None, margin: float
) -> bool:
    """:func:`could_reach` for a TCP position ``(3,)`` and rotation matrix ``(3, 3)``."""
    flange_reach, tcp_reach = workspace(robot)
    bpos, born = p.getBasePositionAndOrientation(robot.body, physicsClientId=robot.client)
    brot = np.array(p.getMatrixFromQuaternion(born)).reshape(3, 3)
    geometry = robot.reach_geometry
    centre = np.asarray(bpos) + brot @ geometry.centre
    grow = geometry.shoulder_offset + margin
    if float(np.linalg.norm(tcp_pos - centre)) > tcp_reach + grow:
        return False
    if tcp_rot is None:
        return True
    flange = tcp_pos + tcp_rot @ geometry.flange_in_tcp
    return float(np.linalg.norm(flange - centre)) <= flange_reach + grow


def measure_workspace(
    robot: RobotBody, samples: int = WORKSPACE_SAMPLES, seed: int = 0
) -> tuple[float, float]:
    """``(max flange distance, max TCP distance)`` from the shoulder, metres.

    Random joint vectors within the limits, then a local random search from the best
    few (stretched-out configurations are rare among uniform samples). The robot's
    configuration is restored afterwards.
    """
    rng = np.random.default_rng(seed)
    saved = robot.joint_positions()
    links = [robot.shoulder_link, robot.flange_link, robot.tcp_link]

    def dists(q: np.ndarray) -> tuple[float, float]:
        robot._reset_arm(q)
        # One forward-kinematics call for the three links (the same values as three).
        sh, flange, tcp = (
            np.array(s[4])
            for s in p.getLinkStates(
                robot.body, links, computeForwardKinematics=True, physicsClientId=robot.client
            )
        )
        return float(np.linalg.norm(flange - sh)), float(np.linalg.norm(tcp - sh))

    result = []
    for which in (0, 1):
        qs = rng.uniform(robot.lower, robot.upper, size=(samples, robot.dof))
        scores = np.array([dists(q)[which] for q in qs])
        best = scores.max()
        for idx in np.argsort(scores)[-5:]:
            q, val = qs[idx], scores[idx]
            for sigma in (0.3, 0.1, 0.03, 0.01):
                for _ in range(60):
                    cand = np.clip(q + rng.normal(0, sigma, robot.dof), robot.lower, robot.upper)
                    d = dists(cand)[which]
                    if d > val:
                        q, val = cand, d
            best = max(best, val)
        result.append(float(best))
    robot._reset_arm(saved)
    return result[0], result[1]
