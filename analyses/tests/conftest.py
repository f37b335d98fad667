"""Fixtures of the analyses' tests: every test writes generated URDFs to its own cache
directory; a small synthetic dataset; one simulator-backed test scene."""

from __future__ import annotations

from pathlib import Path

import pytest


@pytest.fixture(autouse=True, scope="session")
def _isolated_cache(tmp_path_factory: pytest.TempPathFactory) -> None:
    mp = pytest.MonkeyPatch()
    mp.setenv("MOMAKITCHEN_CACHE", str(tmp_path_factory.mktemp("cache")))
    mp.setenv("MPLBACKEND", "Agg")
    yield
    mp.undo()


@pytest.fixture(scope="module")
def small_dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Five synthetic scenes (4 train, 1 test), 2 configurations x 3 episodes each."""
    from momakitchen.data.generator import GenerateRequest, generate_dataset
    from momakitchen.data.synthetic_scene import SyntheticSceneConfig, synthetic_scene_records

    root = tmp_path_factory.mktemp("ds") / "small"
    generate_dataset(
        GenerateRequest(out=root, num_scenes=5),
        synthetic_scene_records,
        SyntheticSceneConfig(configs_per_scene=2, episodes_per_config=3),
        progress=False,
        write_card=False,
    )
    return root


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
