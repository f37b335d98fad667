"""Slow end-to-end runs: the simulator-backed producer, and the Ray backend."""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pytest

from momakitchen.data import EpisodeDataset
from momakitchen.data.batch import EpisodeCollator
from momakitchen.data.generator import GenerateRequest, generate_dataset
from momakitchen.data.integrity import FLOOR_Z_MAX, check_dataset, dataset_stats
from momakitchen.data.manifest import generation_config, load_manifest
from momakitchen.data.shard import SceneShard, list_shards
from momakitchen.data.synthetic_scene import SyntheticSceneConfig, synthetic_scene_records

pytestmark = pytest.mark.slow


def _digests(root: Path) -> dict[str, str]:
    files = [*sorted((root / "scenes").iterdir()), root / "manifest.json"]
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in files}


def test_real_producer_two_scenes_any_worker_count(tmp_path):
    from momakitchen.data.config import GenerationConfig
    from momakitchen.generation.producer import scene_records
    from momakitchen.scene.configuration import SceneConfig

    cfg = GenerationConfig(scene=SceneConfig(configs_per_scene=1))
    a, b = tmp_path / "a", tmp_path / "b"
    generate_dataset(
        GenerateRequest(out=a, num_scenes=2, workers=2), scene_records, cfg, progress=False
    )
    generate_dataset(
        GenerateRequest(out=b, num_scenes=2, workers=1),
        scene_records,
        cfg,
        progress=False,
        write_card=False,
    )
    # Shards are byte-identical across worker counts and processes, physics included (each
    # configuration is simulated in a fresh world; robot caches are computed apart).
    assert _digests(a) == _digests(b)
    with SceneShard(list_shards(a)[1]) as sa:
        assert sum(len(eps) for _, eps in sa.records()) >= 1
    report = check_dataset(a)
    assert report["shards"] == 2 and report["episodes"] >= 2
    stats = dataset_stats(a)
    assert stats["image_shape"] == [480, 640, 3]
    ds = EpisodeDataset(a, split="all")
    sample = ds[0]
    assert len(ds) == report["episodes"] - stats["episodes_with_empty_cloud"]
    assert float(sample["floor_xyz"][:, 2].max()) < FLOOR_Z_MAX
    assert (sample["global_align"] == 1).any()  # the target is visible in every kept view
    batch = EpisodeCollator(num_global=4096, num_floor=1024)([ds[i] for i in range(2)])
    assert batch["global_xyz"].shape == (2, 4096, 3) and batch["floor_label"].shape == (2, 1024)
    assert np.isfinite(batch["floor_label"].numpy()).all()
    assert (a / "README.md").is_file() and (a / "example.png").stat().st_size > 10_000
    assert generation_config(load_manifest(a)) == cfg


def test_ray_backend_on_a_local_instance_matches_local(tmp_path):
    pytest.importorskip("ray")
    cfg = SyntheticSceneConfig(configs_per_scene=2, episodes_per_config=2)
    generate_dataset(
        GenerateRequest(out=tmp_path / "ray", num_scenes=4, workers=2, backend="ray"),
        synthetic_scene_records,
        cfg,
        progress=False,
        write_card=False,
    )
    generate_dataset(
        GenerateRequest(out=tmp_path / "local", num_scenes=4),
        synthetic_scene_records,
        cfg,
        progress=False,
        write_card=False,
    )
    assert _digests(tmp_path / "ray") == _digests(tmp_path / "local")
    assert check_dataset(tmp_path / "ray")["episodes"] == 16
