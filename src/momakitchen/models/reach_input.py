"""The robot's reachability of the target from every floor point, as a model input.

A model with ``ModelConfig.reach_input`` reads, beside each floor point's position, what
the robot's own arm can do from there: the inverse-reachability map of the placement
stage (:class:`~momakitchen.sim.reachability.ReachabilityMap`, sampled from the
robot's URDF and YAML, the same definition ``--method reachability`` places bases by)
queried at the target's centroid (or, with ``ModelConfig.reach_points`` K > 1, at K of
its visible points, each channel the best of them), for a base standing on the point and
facing the target.
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
from momakitchen.sim.reachability import MIN_SCORE, ReachabilityMap

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
          the floor), or (K, 3) K of its points (each channel: the best of them);
          ``floor_xyz``: (N, 3) floor points in that frame
        - output: (N, REACH_CHANNELS) float32
    """
    mount = round(round(float(mount_height) / MOUNT_STEP) * MOUNT_STEP, 6)
    rmap = ReachabilityMap.for_robot(robot, mount)
    xy = np.asarray(floor_xyz, np.float64).reshape(-1, 3)[:, :2]
    targets = np.asarray(target_xyz, np.float64).reshape(-1, 3)
    k, n = len(targets), len(xy)
    # Every (target point, floor point) pair at once: K blocks of the N floor points.
    xy, target = np.tile(xy, (k, 1)), np.repeat(targets, n, axis=0)
    horizontal = rmap.tcp_coordinates(xy, target, None)
    side = rmap.signed_distance(*horizontal)
    down = rmap.signed_distance(*rmap.tcp_coordinates(xy, target, _DOWN))
    index = np.clip(rmap.reachability_index(*horizontal[:2]), 0.0, 1.0)
    out = np.stack(
        [np.clip(side / REACH_SCALE, -1.0, 1.0), np.clip(down / REACH_SCALE, -1.0, 1.0), index],
        axis=-1,
    )
    return out.reshape(k, n, REACH_CHANNELS).max(axis=0).astype(np.float32)


def target_centroid(xyz: torch.Tensor, align: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    """Mean position of the real points flagged as target (alignment +1); zeros if none.

    Shapes:
        - ``xyz``: (B, N, 3), ``align``: (B, N), ``mask``: (B, N) bool; output: (B, 3)
    """
    w = ((align > 0.5) & mask).to(xyz.dtype)
    return (xyz * w.unsqueeze(-1)).sum(1) / w.sum(1, keepdim=True).clamp_min(1.0)


def target_points(
    xyz: torch.Tensor, align: torch.Tensor, mask: torch.Tensor, centroid: torch.Tensor, k: int
) -> torch.Tensor:
    """``k`` of each episode's target points (alignment +1, real), evenly spaced in the
    cloud's order (which the preprocessing draws over the whole view, so they spread over
    the target); the centroid repeated where an episode shows fewer than ``k``.

    Shapes:
        - ``xyz``: (B, N, 3), ``align``: (B, N), ``mask``: (B, N) bool, ``centroid``: (B, 3)
        - output: (B, k, 3)
    """
    out = centroid.unsqueeze(1).repeat(1, k, 1)
    flags = ((align > 0.5) & mask).detach().cpu()
    for i in range(xyz.shape[0]):
        idx = torch.nonzero(flags[i]).flatten()
        if len(idx) >= k:
            pick = idx[torch.linspace(0, len(idx) - 1, k).round().long()]
            out[i] = xyz[i, pick.to(xyz.device)]
    return out


def reach_targets(batch: dict, centroid: torch.Tensor, points: int) -> torch.Tensor:
    """Where a batch's reachability is read: the target's centroid (``points`` 1), else
    ``points`` of its points (:func:`target_points`). Shapes: -> (B, 3) or (B, points, 3)"""
    if points == 1:
        return centroid
    xyz, align, mask = batch["global_xyz"], batch["global_align"], batch["global_mask"]
    return target_points(xyz, align, mask, centroid, points)


def batch_floor_reach(
    robots: Sequence[str], mount: torch.Tensor, target: torch.Tensor, floor_xyz: torch.Tensor
) -> torch.Tensor:
    """:func:`floor_reach` for a batch: each episode's robot by name (``robot_name``, a
    registered robot) at its mount height (its descriptor's ``mount_height_m``); with K
    target points per episode, each channel's maximum over them.

    Shapes:
        - ``robots``: B names; ``mount``: (B,) metres; ``target``: (B, 3) or (B, K, 3);
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
    if targets.ndim == 2:
        targets = targets[:, None]
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


def reach_gate(
    batch: dict, width: float, points: int, index: float = 0.0, picks_only: bool = False
) -> torch.Tensor:
    """How much of a prediction the robot's reachability lets through
    (``ModelConfig.reach_gate`` and ``ModelConfig.index_gate``) at each floor point:

    - with ``width`` > 0, ``sigmoid(d / width)``, where ``d`` (m) is how far inside the
      arm's reachable region the target lies for a base there facing it, the better of a
      horizontal and a top-down approach, at the best of ``points`` of the target's
      points (1: its centroid); ``d`` saturates at :data:`REACH_SCALE`;
    - with ``index`` > 0, times ``min(1, r / index)``, ``r`` the reachability index of the
      target from there (channel 2 of :func:`floor_reach`), at least
      :data:`~momakitchen.sim.reachability.MIN_SCORE`: a stance at the edge of the arm's
      reach, where a few centimetres of the target's unseen depth or of the grasp's
      orientation lose it, counts less; one the arm reaches from at least ``index`` of
      the approach directions counts fully (1: the plain index); with ``picks_only``,
      not where the batch's ``target_opens`` says the target opens.

    Shapes: a batch (``floor_xyz`` (B, Nf, 3), the global cloud, ``robot``,
    ``robot_name``, optionally ``target_opens`` (B,) bool) -> (B, Nf) in (0, 1]
    """
    target = target_centroid(batch["global_xyz"], batch["global_align"], batch["global_mask"])
    at = reach_targets(batch, target, points)
    mount = batch.get("robot_mount", batch["robot"][:, 1])
    reach = batch_floor_reach(batch.get("robot_name", []), mount, at, batch["floor_xyz"])
    gate = torch.ones_like(reach[..., 0])
    if width > 0:
        inside = torch.maximum(reach[..., 0], reach[..., 1]) * REACH_SCALE
        gate = torch.sigmoid(inside / width)
    if index > 0:
        weight = (reach[..., 2] / index).clamp(MIN_SCORE, 1.0)
        opens = batch.get("target_opens")
        if picks_only and opens is not None:
            weight = torch.where(opens.to(weight.device)[:, None], 1.0, weight)
        gate = gate * weight
    return gate


def footprint_gate(batch: dict) -> torch.Tensor:
    """Where the robot's base fits (``ModelConfig.footprint_gate``): 1 at each floor point
    where its box, facing the target, holds none of the view's obstacle points up to the
    arm's mount, else 0 (:func:`~momakitchen.perception.footprint.footprint_free`, the
    test the classical methods place by). The obstacle points are the batch's
    ``obstacle_xyz`` (from each whole cloud: the collator of a gated model adds them),
    else those of its global cloud, which a model's sampling down may have thinned. A
    registered robot's footprint is its own, a robot given by its numbers the built-ins'.

    Shapes: a batch (``floor_xyz`` (B, Nf, 3), the global cloud, ``robot``,
    ``robot_name``, optionally ``obstacle_xyz`` (B, No, 3) and ``obstacle_mask``) ->
    (B, Nf) in {0, 1}
    """
    from momakitchen.perception.footprint import base_obstacles, footprint_free
    from momakitchen.robots.spec import DEFAULT_FOOTPRINT

    target = target_centroid(batch["global_xyz"], batch["global_align"], batch["global_mask"])
    mounts = batch.get("robot_mount", batch["robot"][:, 1]).detach().cpu().double().numpy()
    floor = batch["floor_xyz"].detach().cpu().double().numpy()
    targets = target.detach().cpu().double().numpy()
    if "obstacle_xyz" in batch:
        points = batch["obstacle_xyz"].detach().cpu().double().numpy()
        real = batch["obstacle_mask"].detach().cpu().numpy()
        obstacles = [points[i][real[i]] for i in range(len(floor))]
    else:
        points = batch["global_xyz"].detach().cpu().double().numpy()
        real = batch["global_mask"].detach().cpu().numpy()
        obstacles = [base_obstacles(points[i][real[i]]) for i in range(len(floor))]
    names = list(batch.get("robot_name", [])) or [""] * len(floor)
    out = np.ones(floor.shape[:2], np.float32)
    for i, name in enumerate(names):
        footprint = get_robot_spec(str(name)).footprint if name else DEFAULT_FOOTPRINT
        out[i] = footprint_free(floor[i], obstacles[i], targets[i], footprint, float(mounts[i]))
    return torch.from_numpy(out).to(device=batch["floor_xyz"].device)
