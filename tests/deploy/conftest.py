"""Fixtures of the deployment tests: one real generated view."""

from __future__ import annotations

from pathlib import Path

import pytest


@pytest.fixture(scope="session")
def real_view(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A one-scene dataset from the simulator-backed producer: 1 configuration x 2 views."""
    from momakitchen.data.config import GenerationConfig, ViewConfig
    from momakitchen.data.generator import GenerateRequest, generate_dataset
    from momakitchen.generation.producer import scene_records
    from momakitchen.scene.configuration import SceneConfig

    root = tmp_path_factory.mktemp("view") / "ds"
    cfg = GenerationConfig(scene=SceneConfig(configs_per_scene=1), views=ViewConfig(episodes=2))
    generate_dataset(
        GenerateRequest(out=root, num_scenes=1, first_scene_id=3),
        scene_records,
        cfg,
        progress=False,
        write_card=False,
    )
    return root
