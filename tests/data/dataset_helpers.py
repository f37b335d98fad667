"""Helpers of the dataset tests: small synthetic datasets written by the real generator."""

from __future__ import annotations

from pathlib import Path

from momakitchen.data.generator import GenerateRequest, generate_dataset
from momakitchen.data.synthetic_scene import SyntheticSceneConfig, synthetic_scene_records

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


def slow_scene_records(scene_id: int, config: SyntheticSceneConfig):
    """Synthetic records, a minute late for every scene but the first: a worker busy with a
    long scene."""
    import time

    if scene_id > 0:
        time.sleep(60)
    return synthetic_scene_records(scene_id, config)
