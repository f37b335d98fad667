"""The robot's reachability of the target from every floor point, as a model input.

A model with ``ModelConfig.reach_input`` reads, beside each floor point's position, what
the robot's own arm can do from there: the inverse-reachability map of the placement
stage (:class:`~momakitchen.sim.reachability.ReachabilityMap`, sampled from the
robot's URDF and YAML, the same definition ``--method reachability`` places bases by)
queried at the target's centroid, for a base standing on the point and facing the target.
A user's robot and a built-in get their input from one definition, their URDF and mount:
nothing about a robot is a number the model learnt for that robot's name.

Channels (:data:`REACH_CHANNELS`), per floor point:

0. how far inside the arm's reachable region the target lies with a horizontal
   approach, in units of :data:`REACH_SCALE` and clipped to [-1, 1] (negative: outside);
1. the same for a top-down approach;
2. the reachability index of the target's position from there: the share of approach
   directions (of every pitch and yaw class) by which the arm reaches it, 0 where none
   does. It is the most generous of the three: a grasp need not come straight at the
   target, and the labelling's trials try tilted approaches too.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import torch

from momakitchen.errors import MomaError
from momakitchen.robots.spec import get_robot_spec
from momakitchen.sim.reachability import ReachabilityMap

REACH_CHANNELS = 3
# The signed distance (m) at which a channel saturates: a few centimetres decide between
# reaching and not, half a metre inside is as good as a quarter.
REACH_SCALE = 0.25
# Mounts are looked up to the centimetre: the map's cells are 5 cm, and a map per
# millimetre of a continuous mount range would fill memory for nothing.
MOUNT_STEP = 0.01
_DOWN = np.array([0.0, 0.0, -1.0])


def floor_reach(
    robot: str, mount_height: float, target_xyz: np.ndarray, floor_xyz: np.ndarray
) -> np.ndarray:
    """The reachability channels of one episode (module docstring).

    Shapes:
        - ``target_xyz``: (3,) the target in the robot base frame of the view (z = 0 on
          the floor); ``floor_xyz``: (N, 3) floor points in that frame
        - output: (N, REACH_CHANNELS) float32
    """
    mount = round(round(float(mount_height) / MOUNT_STEP) * MOUNT_STEP, 6)
    rmap = ReachabilityMap.for_robot(robot, mount)
    xy = np.asarray(floor_xyz, np.float64).reshape(-1, 3)[:, :2]
    target = np.asarray(target_xyz, np.float64).reshape(3)
    horizontal = rmap.tcp_coordinates(xy, target, None)
    side = rmap.signed_distance(*horizontal)
    down = rmap.signed_distance(*rmap.tcp_coordinates(xy, target, _DOWN))
    index = np.clip(rmap.reachability_index(*horizontal[:2]), 0.0, 1.0)
    out = np.stack(
        [np.clip(side / REACH_SCALE, -1.0, 1.0), np.clip(down / REACH_SCALE, -1.0, 1.0), index],
        axis=-1,
    )
    return out.astype(np.float32)


def batch_floor_reach(
    robots: Sequence[str], mount: torch.Tensor, target: torch.Tensor, floor_xyz: torch.Tensor
) -> torch.Tensor:
    """:func:`floor_reach` for a batch: each episode's robot by name (``robot_name``, a
    registered robot) at its mount height (its descriptor's ``mount_height_m``).

    Shapes:
        - ``robots``: B names; ``mount``: (B,) metres; ``target``: (B, 3);
          ``floor_xyz``: (B, N, 3)
        - output: (B, N, REACH_CHANNELS), ``floor_xyz``'s dtype and device
    """
    if len(robots) != floor_xyz.shape[0]:
        raise MomaError(
            f"a model that reads the robot's reachability needs each episode's robot name "
            f"(batch['robot_name'], {floor_xyz.shape[0]} of them), got {list(robots)!r}"
        )
    mounts = mount.detach().cpu().double().numpy()
    targets = target.detach().cpu().double().numpy()
    points = floor_xyz.detach().cpu().double().numpy()
    out = np.zeros((*points.shape[:2], REACH_CHANNELS), np.float32)
    for i, name in enumerate(robots):
        if not name:
            raise MomaError(
                "a model that reads the robot's reachability needs each episode's robot "
                "name (batch['robot_name']); episode "
                f"{i} has none"
            )
        try:
            get_robot_spec(str(name))
        except MomaError:
            raise MomaError(
                f"this model reads the robot's reachability from its URDF: robot {name!r} "
                "is not registered (give a registered robot's name, or register yours with "
                "--robot-yaml; a robot given by its numbers has no URDF)"
            ) from None
        out[i] = floor_reach(str(name), float(mounts[i]), targets[i], points[i])
    return torch.from_numpy(out).to(device=floor_xyz.device, dtype=floor_xyz.dtype)
