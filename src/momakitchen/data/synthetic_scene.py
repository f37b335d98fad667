"""Synthetic scene records: a fast stand-in for the simulator-backed producer.

:func:`synthetic_scene_records` has the signature of
:func:`momakitchen.perception.episodes.scene_records` and returns records of the same
types, shapes and dtypes (small images and clouds; floor labels a smooth ring around the
target within the robot's reach, zero near the obstacle), deterministic in
``(scene_id, config)``. It exercises the storage, the generator, the integrity checks and
the torch Dataset in seconds; ``momakitchen generate --synthetic`` writes such a dataset
(the manifest records the producer, so it is never mistaken for the benchmark).
Robots are assigned to configurations exactly as :class:`SceneConfig` does.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from momakitchen.data.episode import ConfigurationLabels, Episode
from momakitchen.errors import MomaError
from momakitchen.robots.descriptor import robot_descriptor
from momakitchen.robots.spec import get_robot_spec
from momakitchen.scene.configuration import SceneConfig

TARGETS = (
    "bottle",
    "pot",
    "fruit",
    "cabinet/door",
    "cabinet/drawer",
    "microwave/door",
    "fridge/door",
    "dishwasher/door",
)


@dataclass(frozen=True)
class SyntheticSceneConfig:
    """Sizes of synthetic scene records.

    Attributes:
        configs_per_scene: configurations per scene.
        episodes_per_config: episodes (views) per configuration.
        image_size: (height, width) of the images.
        num_global: global points per episode (before a random 0-20 % drop).
        num_floor: floor points per episode (before a random 0-20 % drop).
        seconds_per_scene: artificial work time per scene (to test progress and kills).
    """

    configs_per_scene: int = 3
    episodes_per_config: int = 4
    image_size: tuple[int, int] = (24, 32)
    num_global: int = 384
    num_floor: int = 160
    seconds_per_scene: float = 0.0

    def __post_init__(self) -> None:
        if not 1 <= self.configs_per_scene <= 1000:
            raise MomaError(f"configs_per_scene must be in [1, 1000], got {self.configs_per_scene}")
        if not 1 <= self.episodes_per_config <= 1000:
            raise MomaError(
                f"episodes_per_config must be in [1, 1000], got {self.episodes_per_config}"
            )
        if len(self.image_size) != 2 or min(self.image_size) < 1:
            raise MomaError(f"image_size must be two positive ints, got {self.image_size}")
        if self.num_global < 16 or self.num_floor < 8:
            raise MomaError(
                f"num_global >= 16 and num_floor >= 8 required, got "
                f"{self.num_global}, {self.num_floor}"
            )
        if not 0.0 <= self.seconds_per_scene <= 60.0:
            raise MomaError(f"seconds_per_scene must be in [0, 60], got {self.seconds_per_scene}")


def synthetic_scene_records(
    scene_id: int,
    config: SyntheticSceneConfig,
    progress: Callable[[int, int], None] | None = None,
) -> list[tuple[ConfigurationLabels, list[Episode]]]:
    """Records of scene ``scene_id``: one entry per configuration with its episodes;
    ``progress(done, total)`` after each configuration, as the real producer reports."""
    names = SceneConfig().robot_names
    out = []
    for c in range(config.configs_per_scene):
        if config.seconds_per_scene > 0:  # the artificial work, spread over configurations
            time.sleep(config.seconds_per_scene / config.configs_per_scene)
        rng = np.random.default_rng([7, scene_id, c])
        robot = names[(scene_id * 7 + c) % len(names)]  # as sample_configuration assigns
        desc = np.asarray(robot_descriptor(get_robot_spec(robot)), np.float32)
        anchor = (
            float(rng.uniform(1.5, 2.5)),
            float(rng.uniform(-1, 1)),
            float(rng.uniform(0.85, 0.95)),
        )
        grid = np.stack(np.meshgrid(np.arange(-6, 7) * 0.1, np.arange(1, 8) * 0.1), -1)
        pos = grid.reshape(-1, 2)[:, ::-1] * np.array([-1.0, 1.0]) + np.array(anchor[:2])
        r = np.hypot(pos[:, 0] - anchor[0], pos[:, 1] - anchor[1])
        stages = np.where(
            (r > 0.35) & (r < desc[0]) & (rng.random(len(r)) < 0.8), 0, rng.integers(1, 6, len(r))
        ).astype(np.uint8)
        labels = ConfigurationLabels(
            scene_id=scene_id,
            config_index=c,
            robot=robot,
            target=TARGETS[int(rng.integers(len(TARGETS)))],
            anchor=anchor,
            trial_positions=pos.astype(np.float64),
            trial_yaws=np.arctan2(anchor[1] - pos[:, 1], anchor[0] - pos[:, 0]),
            trial_stages=stages,
            trial_moved=(stages == 0).astype(np.float32) * 0.1,
        )
        episodes = [
            _episode(scene_id, c, e, robot, desc, config) for e in range(config.episodes_per_config)
        ]
        out.append((labels, episodes))
        if progress is not None:
            progress(len(out), config.configs_per_scene)
    return out


def _episode(
    scene_id: int, c: int, e: int, robot: str, desc: np.ndarray, cfg: SyntheticSceneConfig
) -> Episode:
    rng = np.random.default_rng([11, scene_id, c, e])
    h, w = cfg.image_size
    ng = cfg.num_global - int(rng.integers(0, cfg.num_global // 5 + 1))
    nf = cfg.num_floor - int(rng.integers(0, cfg.num_floor // 5 + 1))
    front = float(rng.uniform(1.5, 3.0))
    target = np.array([front + 0.2, rng.uniform(-0.5, 0.5), 0.95])
    obstacles = np.array([[front - 0.7, rng.uniform(-1, 1), 0.4, 0.4, 0.6]])
    floor = np.stack(
        [rng.uniform(0.3, front, nf), rng.uniform(-1.5, 1.5, nf), rng.uniform(0.0, 0.015, nf)], 1
    ).astype(np.float32)
    r = np.hypot(floor[:, 0] - target[0], floor[:, 1] - target[1])
    label = np.exp(-((r - 0.6 * desc[0]) ** 2) / (2 * (0.25 * desc[0]) ** 2))
    label[
        (r > desc[0])
        | (np.hypot(floor[:, 0] - obstacles[0, 0], floor[:, 1] - obstacles[0, 1]) < 0.4)
    ] = 0.0
    label = label.astype(np.float32)
    gxyz = np.concatenate(
        [
            floor[: ng // 3],
            np.stack(
                [
                    rng.uniform(0.3, front + 0.6, ng - ng // 3),
                    rng.uniform(-1.5, 1.5, ng - ng // 3),
                    rng.uniform(0.0, 2.0, ng - ng // 3),
                ],
                1,
            ).astype(np.float32),
        ]
    )
    align = np.zeros(ng, np.int8)
    align[np.linalg.norm(gxyz - target.astype(np.float32), axis=1) < 0.3] = 1
    align[
        (np.abs(gxyz[:, 0] - obstacles[0, 0]) < 0.2)
        & (np.abs(gxyz[:, 1] - obstacles[0, 1]) < 0.2)
        & (gxyz[:, 2] > 0.02)
    ] = -1
    depth = rng.uniform(0.5, 4.0, (h, w)).astype(np.float32)
    depth[0, : w // 4] = 0.0  # no return
    cam = np.eye(4)
    cam[:3, 3] = (rng.uniform(-1, 1), rng.uniform(-1, 1), float(desc[1]) + 0.3)
    c2b = np.array(
        [[0, 0, 1, 0], [-1, 0, 0, 0], [0, -1, 0, float(desc[1]) + 0.3], [0, 0, 0, 1]], np.float64
    )
    return Episode(
        scene_id=scene_id,
        config_index=c,
        episode_index=e,
        robot=robot,
        descriptor=desc,
        rgb=rng.integers(0, 256, (h, w, 3), dtype=np.uint8),
        depth=depth,
        semantic=rng.integers(0, 8, (h, w), dtype=np.uint8),
        intrinsics=np.array([w * 0.8, w * 0.8, w / 2, h / 2]),
        camera_pose=cam,
        base_pose=(
            float(rng.uniform(-1, 1)),
            float(rng.uniform(-1, 1)),
            float(rng.uniform(-np.pi, np.pi)),
        ),
        camera_to_base=c2b,
        global_xyz=gxyz,
        global_rgb=rng.integers(0, 256, (ng, 3), dtype=np.uint8),
        global_align=align,
        floor_xyz=floor,
        floor_label=label,
    )
