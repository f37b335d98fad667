"""Helpers of the dataset tests: small synthetic datasets written by the real generator."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from momakitchen.data.generator import GenerateRequest, generate_dataset
from momakitchen.data.synthetic_scene import SyntheticSceneConfig, synthetic_scene_records
from momakitchen.scene.configuration import SceneConfig

SMALL = SyntheticSceneConfig(configs_per_scene=2, episodes_per_config=3)


def make_dataset(
    root: Path,
    scenes: int = 5,
    config: SyntheticSceneConfig = SMALL,
    workers: int = 1,
    card: bool = False,
    split: str | None = None,
) -> dict:
    return generate_dataset(
        GenerateRequest(out=root, num_scenes=scenes, workers=workers, split=split),
        synthetic_scene_records,
        config,
        progress=False,
        write_card=card,
    )


# Where slow_scene_records leaves its marks (an environment variable: pool workers inherit it).
SLOW_MARKS = "MOMAKITCHEN_TEST_SLOW_MARKS"


def slow_scene_records(scene_id: int, config: SyntheticSceneConfig):
    """Synthetic records, a minute late for every scene but the first: a worker busy with a
    long scene. With ``SLOW_MARKS`` set to a folder, the worker writes its pid there as
    ``busy.pid`` when it starts a long scene and ``finished`` when it has done one."""
    import os
    import time

    marks = os.environ.get(SLOW_MARKS)
    if scene_id > 0:
        if marks:
            part = Path(marks) / f"busy.pid.{os.getpid()}"
            part.write_text(str(os.getpid()))
            part.replace(Path(marks) / "busy.pid")
        time.sleep(60)
        if marks:
            (Path(marks) / "finished").touch()
    return synthetic_scene_records(scene_id, config)


PYBULLET_PANDA = "franka_panda/panda.urdf"


def write_panda_yaml(folder: Path, name: str = "pandalow", mount_height: object = 0.6) -> Path:
    """A user robot: the Panda URDF shipped with pybullet_data (its hand and fingers), at
    ``mount_height`` (a number or ``[lo, hi]``)."""
    import pybullet_data

    urdf = Path(pybullet_data.getDataPath()) / PYBULLET_PANDA
    path = folder / f"{name}.yaml"
    path.write_text(
        f"name: {name}\nurdf: {urdf}\nmount_height: {mount_height}\n"
        "end_effector_link: panda_grasptarget\nend_effector: parallel_gripper\nreach: 0.85\n"
    )
    return path


@dataclass(frozen=True)
class RobotRecordsConfig:
    """Config of :func:`robot_records`: synthetic records labelled with ``scene``'s robots."""

    scene: SceneConfig = field(default_factory=SceneConfig)
    configs_per_scene: int = 2


def robot_records(scene_id: int, config: RobotRecordsConfig):
    """Synthetic records whose configurations name ``config.scene``'s robots, with their
    descriptors: only a process where those robots are registered can make them."""
    import dataclasses

    import numpy as np

    from momakitchen.robots.descriptor import robot_descriptor
    from momakitchen.robots.spec import get_robot_spec

    small = SyntheticSceneConfig(configs_per_scene=config.configs_per_scene, episodes_per_config=1)
    names = config.scene.robot_names
    out = []
    for c, (labels, episodes) in enumerate(synthetic_scene_records(scene_id, small)):
        name = names[c % len(names)]
        desc = np.asarray(robot_descriptor(get_robot_spec(name)), np.float32)
        out.append(
            (
                dataclasses.replace(labels, robot=name),
                [dataclasses.replace(e, robot=name, descriptor=desc) for e in episodes],
            )
        )
    return out
