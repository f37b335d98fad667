"""A tiny synthetic episode factory with the batch contract (tests, benchmarks, smoke runs).

Each episode is a counter box along a wall, a target object on the counter, one to three
obstacle boxes on the floor in front of it and a floor patch, seen from a robot base at the
origin (x forward, y left, z up). The label of a floor point is a smooth function of the
geometry **and** the robot descriptor: high at a comfortable distance from the target,
within the robot's effective horizontal reach (arm reach shortened by the height difference
between the arm mount and the target), zero where the base would hit the counter or an
obstacle. It is not the benchmark's physics-based label, but it asks a model the same
question: use the target, the obstacles and the robot together.

Everything is derived from ``(seed, index)``: the same config always yields the same data.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from torch.utils.data import Dataset

from momakitchen.errors import MomaError
from momakitchen.robots.descriptor import robot_descriptor
from momakitchen.robots.spec import DEFAULT_ROBOTS, get_robot_spec

EPISODES_PER_CONFIG = 10
CONFIGS_PER_SCENE = 2


@dataclass(frozen=True)
class SyntheticConfig:
    """Size and randomness of a synthetic dataset.

    Attributes:
        num_episodes: number of episodes (dataset length).
        num_global: largest global cloud size; actual sizes vary in
            [``min_fill`` * num_global, num_global] so batches need padding.
        num_floor: largest floor cloud size, same rule.
        seed: base seed; episode ``i`` is generated from ``(seed, i)``.
        robots: robot names drawn from (uniformly, per configuration of 10 episodes).
        min_fill: smallest fraction of the point budget an episode uses (1.0: fixed sizes).
    """

    num_episodes: int = 16
    num_global: int = 2048
    num_floor: int = 1024
    seed: int = 0
    robots: tuple[str, ...] = DEFAULT_ROBOTS
    min_fill: float = 0.75

    def __post_init__(self) -> None:
        if self.num_episodes < 1:
            raise MomaError(f"num_episodes must be >= 1, got {self.num_episodes}")
        if self.num_global < 16:
            raise MomaError(f"num_global must be >= 16, got {self.num_global}")
        if self.num_floor < 8:
            raise MomaError(f"num_floor must be >= 8, got {self.num_floor}")
        if not 0.05 <= self.min_fill <= 1.0:
            raise MomaError(f"min_fill must be in [0.05, 1], got {self.min_fill}")
        if not self.robots:
            raise MomaError("robots must name at least one robot")
        for name in self.robots:
            get_robot_spec(name)


def _box_distance_2d(px: np.ndarray, py: np.ndarray, box: np.ndarray) -> np.ndarray:
    """Distance from floor points to an axis-aligned footprint (cx, cy, sx, sy, h)."""
    dx = np.maximum(np.abs(px - box[0]) - box[2] / 2, 0.0)
    dy = np.maximum(np.abs(py - box[1]) - box[3] / 2, 0.0)
    return np.hypot(dx, dy)


def affordance_label(
    floor_xy: np.ndarray,
    target: np.ndarray,
    counter_front_x: float,
    obstacles: np.ndarray,
    descriptor: np.ndarray,
) -> np.ndarray:
    """Synthetic affordance value of floor points for a robot.

    Shapes:
        - ``floor_xy``: (n, 2); ``target``: (3,); ``obstacles``: (k, 5) rows
          (cx, cy, sx, sy, height); ``descriptor``: (DESCRIPTOR_DIM,)
        - output: (n,) float32 in [0, 1]
    """
    reach, mount = float(descriptor[0]), float(descriptor[1])
    suction = float(descriptor[3]) > 0.5
    dz = float(target[2]) - mount
    horizontal = np.sqrt(max((1.15 * reach) ** 2 - dz**2, 0.0))
    if suction:
        horizontal *= 0.9
    px, py = floor_xy[:, 0], floor_xy[:, 1]
    r = np.hypot(px - target[0], py - target[1])
    best = 0.65 * horizontal
    width = max(0.3 * horizontal, 0.05)
    value = np.exp(-((r - best) ** 2) / (2 * width**2))
    value[r > horizontal] = 0.0
    value[px > counter_front_x - 0.25] = 0.0  # base footprint would hit the counter
    for box in obstacles:
        value[_box_distance_2d(px, py, box) < 0.25] = 0.0
    return value.astype(np.float32)


class SyntheticEpisodes(Dataset):
    """A torch Dataset of synthetic episodes following :mod:`momakitchen.data.batch`."""

    def __init__(self, config: SyntheticConfig | None = None) -> None:
        self.config = config if config is not None else SyntheticConfig()

    def __len__(self) -> int:
        return self.config.num_episodes

    def __getitem__(self, index: int) -> dict:
        if not 0 <= index < len(self):
            raise IndexError(index)
        return make_episode(self.config, index)


def _uniform_box_face(rng, n, x, y, z):
    """Points on an axis-aligned rectangle: each of x, y, z is a value or a (lo, hi) range."""
    cols = []
    for v in (x, y, z):
        if isinstance(v, tuple):
            cols.append(rng.uniform(v[0], v[1], n))
        else:
            cols.append(np.full(n, v))
    return np.stack(cols, axis=1)


def make_episode(config: SyntheticConfig, index: int) -> dict:
    """Generate episode ``index`` of ``config`` as a sample dict (torch tensors + metadata)."""
    cfg_index = index // EPISODES_PER_CONFIG
    crng = np.random.default_rng([config.seed, cfg_index, 1])
    rng = np.random.default_rng([config.seed, index, 2])
    robot_name = config.robots[int(crng.integers(len(config.robots)))]
    spec = get_robot_spec(robot_name)
    desc = np.asarray(robot_descriptor(spec), np.float32)

    # Counter along a wall facing the robot; each episode of a configuration is a slightly
    # different viewpoint (shifted geometry).
    front = crng.uniform(1.4, 2.4) + rng.uniform(-0.3, 0.3)
    shift = crng.uniform(-0.4, 0.4) + rng.uniform(-0.3, 0.3)
    half_w = crng.uniform(0.9, 1.6)
    height = crng.uniform(0.85, 0.95)
    depth = 0.6
    target = np.array(
        [front + crng.uniform(0.1, 0.35), shift + crng.uniform(-0.5, 0.5), height + 0.06]
    )
    n_obs = int(crng.integers(1, 4))
    obstacles = []
    for _ in range(n_obs):
        sx, sy = crng.uniform(0.3, 0.5, 2)
        cx = front - crng.uniform(0.45, 1.1)
        cy = target[1] + crng.uniform(-1.0, 1.0)
        obstacles.append([cx, cy, sx, sy, crng.uniform(0.4, 0.9)])
    obstacles_arr = np.asarray(obstacles, np.float64)

    ng = int(rng.integers(int(config.min_fill * config.num_global), config.num_global + 1))
    nf = int(rng.integers(int(config.min_fill * config.num_floor), config.num_floor + 1))

    # Floor patch in front of the counter, not under obstacles.
    fx = rng.uniform(max(0.4, front - 1.6), front, nf * 2)
    fy = rng.uniform(target[1] - 1.2, target[1] + 1.2, nf * 2)
    free = np.ones_like(fx, dtype=bool)
    for box in obstacles_arr:
        free &= _box_distance_2d(fx, fy, box) > 0.0
    fx, fy = fx[free][:nf], fy[free][:nf]
    while fx.shape[0] < nf:  # rare: pad by repeating free points with jitter
        extra = nf - fx.shape[0]
        fx = np.concatenate([fx, fx[:extra] + rng.normal(0, 0.01, min(extra, fx.shape[0]))])
        fy = np.concatenate([fy, fy[:extra] + rng.normal(0, 0.01, min(extra, fy.shape[0]))])
    floor_xyz = np.stack([fx, fy, rng.uniform(0.0, 0.015, nf)], axis=1)
    label = affordance_label(floor_xyz[:, :2], target, front, obstacles_arr, desc)

    # Global cloud: floor, counter front and top, wall, target, obstacles.
    parts: list[tuple[np.ndarray, np.ndarray, float]] = []
    y0, y1 = shift - half_w, shift + half_w
    wood = crng.uniform(0.3, 0.8, 3)
    n_floor = ng // 4
    parts.append((floor_xyz[rng.integers(0, nf, n_floor)], np.array([0.5, 0.5, 0.5]), 0.0))
    n_front = ng // 6
    parts.append((_uniform_box_face(rng, n_front, front, (y0, y1), (0.0, height)), wood, 0.0))
    n_top = ng // 8
    parts.append(
        (_uniform_box_face(rng, n_top, (front, front + depth), (y0, y1), height), wood * 0.8, 0.0)
    )
    n_target = max(ng // 12, 8)
    ang = rng.uniform(-np.pi / 2, np.pi / 2, n_target) + np.pi
    tz = rng.uniform(height, height + 0.15, n_target)
    tpts = np.stack([target[0] + 0.04 * np.cos(ang), target[1] + 0.04 * np.sin(ang), tz], 1)
    parts.append((tpts, np.array([0.85, 0.15, 0.1]), 1.0))
    n_obs_pts = ng // 8
    for box in obstacles_arr:
        cx, cy, sx, sy, h = box
        m = n_obs_pts // n_obs
        face = _uniform_box_face(rng, m // 2, cx - sx / 2, (cy - sy / 2, cy + sy / 2), (0.0, h))
        top = _uniform_box_face(
            rng, m - m // 2, (cx - sx / 2, cx + sx / 2), (cy - sy / 2, cy + sy / 2), h
        )
        parts.append((np.concatenate([face, top]), crng.uniform(0, 1, 3), -1.0))
    used = sum(p[0].shape[0] for p in parts)
    parts.append(
        (
            _uniform_box_face(rng, ng - used, front + depth, (y0, y1), (height, 2.2)),
            np.array([0.9, 0.9, 0.85]),
            0.0,
        )
    )
    xyz = np.concatenate([p[0] for p in parts]).astype(np.float32)
    rgb = np.concatenate(
        [np.clip(p[1] + rng.normal(0, 0.03, (p[0].shape[0], 3)), 0, 1) for p in parts]
    ).astype(np.float32)
    align = np.concatenate([np.full(p[0].shape[0], p[2]) for p in parts]).astype(np.float32)
    xyz += rng.normal(0, 0.003, xyz.shape).astype(np.float32)
    perm = rng.permutation(ng)
    return {
        "global_xyz": torch.from_numpy(xyz[perm]),
        "global_rgb": torch.from_numpy(rgb[perm]),
        "global_align": torch.from_numpy(align[perm]),
        "floor_xyz": torch.from_numpy(floor_xyz.astype(np.float32)),
        "floor_label": torch.from_numpy(label),
        "robot": torch.from_numpy(desc),
        "scene_id": cfg_index // CONFIGS_PER_SCENE,
        "config_index": cfg_index % CONFIGS_PER_SCENE,
        "episode_index": index % EPISODES_PER_CONFIG,
        "robot_name": robot_name,
    }
