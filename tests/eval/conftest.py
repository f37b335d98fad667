"""Shared fixtures of the evaluation tests."""

from __future__ import annotations

from pathlib import Path

import pytest


@pytest.fixture(scope="session")
def real_dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Scene 0 (a test scene) from the simulator-backed producer: 2 configurations x 2 views."""
    from momakitchen.data.config import GenerationConfig, ViewConfig
    from momakitchen.data.generator import GenerateRequest, generate_dataset
    from momakitchen.generation.producer import scene_records
    from momakitchen.scene.configuration import SceneConfig

    root = tmp_path_factory.mktemp("msr") / "ds"
    cfg = GenerationConfig(scene=SceneConfig(configs_per_scene=2), views=ViewConfig(episodes=2))
    generate_dataset(
        GenerateRequest(out=root, num_scenes=1),
        scene_records,
        cfg,
        progress=False,
        write_card=False,
    )
    return root
