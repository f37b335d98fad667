"""Helpers of the placement tests: a dataset episode as ``place``'s inputs, and the
agreement of a reachability map with inverse kinematics on poses it was not built from."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from momakitchen.sim.sampling import SamplingConfig

# Coarse enough to sample a robot in about two seconds; the slow test checks the default.
COARSE = SamplingConfig(cell=0.1, psi_bins=8, fk_samples=5000)


def frame_of(ep: Any) -> dict[str, Any]:
    """``place``'s inputs of a dataset episode (the target and obstacle masks from its
    semantic image, the robot at the configuration's mount height)."""
    from momakitchen.data.episode import SEMANTIC_CLASSES

    return dict(
        depth=ep.depth,
        intrinsics=ep.intrinsics,
        camera_to_base=ep.camera_to_base,
        target_mask=ep.semantic == SEMANTIC_CLASSES.index("target"),
        robot=ep.robot,
        obstacle_masks=[ep.semantic == SEMANTIC_CLASSES.index("obstacle")],
        # mounts are drawn to the millimetre; the descriptor stores them as float32
        mount_height=round(float(ep.descriptor[1]), 6),
    )


def ik_agreement(
    robot: str, pairs: int, config: SamplingConfig | None = None, seed: int = 7
) -> tuple[float, float]:
    """How often the map of ``robot`` (at its own mount height) and IK agree on whether
    the arm reaches a target pose from a base facing it: ``(agreement, share IK
    reaches)`` over ``pairs`` random (base, target pose) pairs. Targets 0.1-1.9 m high,
    bases 0.3-1.4 m from them, approaches horizontal, 45 degrees down or top-down, turned
    up to 90 degrees from the base's direction: continuous poses, none a cell's centre.
    IK (``solve_ik`` from home, its restarts) is asked at the pose the map is asked about,
    with the map's roll convention (:func:`approach_quaternion`)."""
    from momakitchen.bullet import connect_direct, p
    from momakitchen.placement import ReachabilityMap
    from momakitchen.robots.robot import Robot
    from momakitchen.sim.sampling import approach_quaternion

    reach = ReachabilityMap.for_robot(robot, None, config)
    rng = np.random.default_rng(seed)
    client = connect_direct()
    agree, reached = 0, 0
    try:
        arm = Robot(client, robot)
        for _ in range(pairs):
            target = np.array([0.3, -0.2, rng.uniform(0.1, 1.9)])
            turn = rng.uniform(-math.pi, math.pi)
            u = np.array([math.cos(turn), math.sin(turn)])
            base = target[:2] - rng.uniform(0.3, 1.4) * u
            pitch = math.radians(rng.choice([0.0, 45.0, 90.0]))
            yaw = turn + rng.uniform(-math.pi / 2, math.pi / 2)
            approach = np.array(
                [
                    math.cos(pitch) * math.cos(yaw),
                    math.cos(pitch) * math.sin(yaw),
                    -math.sin(pitch),
                ]
            )
            says = bool(reach.reachable_from(base[None], target, approach)[0])
            arm.place_base(base[0], base[1], turn)
            side = np.array([-u[1], u[0]])
            radial = target[:2] - (base + reach.axis_xy[0] * u + reach.axis_xy[1] * side)
            quat = approach_quaternion(approach, radial / np.linalg.norm(radial))
            solved = arm.solve_ik(target, quat, seed=arm.home).success
            agree += says == solved
            reached += solved
    finally:
        p.disconnect(client)
    return agree / pairs, reached / pairs
