"""Shared fixtures: every test writes generated URDFs to its own cache directory; a tiny
trained run; one real generated view."""

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


@pytest.fixture(scope="session")
def tiny_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A NavAff run with the tiny test sizes, trained for a few steps on synthetic data."""
    from momakitchen.data.synthetic import SyntheticConfig, SyntheticEpisodes
    from momakitchen.models.config import TINY_MODEL
    from momakitchen.train import train
    from momakitchen.train.config import TrainConfig

    data = SyntheticEpisodes(SyntheticConfig(num_episodes=4, num_global=256, num_floor=128))
    cfg = TrainConfig(
        model="navaff",
        preset="custom",
        model_config=TINY_MODEL,
        num_global=256,
        num_floor=128,
        epochs=1,
        batch_size=2,
        progress=False,
    )
    out = tmp_path_factory.mktemp("run") / "tiny"
    train(cfg, data, None, out)
    return out


@pytest.fixture(scope="session")
def real_view(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A one-scene dataset from the simulator-backed producer: 1 configuration x 2 views
    (scene 3; the deployment and placement tests read its frames)."""
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
