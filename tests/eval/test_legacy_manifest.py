"""Datasets whose manifest names the producer by its old import path still load and resume."""

from __future__ import annotations

import json
import shutil

from momakitchen.cli.main import main
from momakitchen.data import manifest as mf
from momakitchen.data.config import GenerationConfig, ViewConfig
from momakitchen.data.generator import GenerateRequest, generate_dataset
from momakitchen.generation.producer import scene_records
from momakitchen.scene.configuration import SceneConfig

OLD_PRODUCER = "momakitchen.perception.episodes.scene_records"
OLD_CONFIG_CLASS = "momakitchen.perception.episodes.GenerationConfig"


def test_a_manifest_naming_the_old_producer_loads_and_resumes(real_dataset, tmp_path):
    root = tmp_path / "old"
    shutil.copytree(real_dataset, root)
    path = mf.manifest_path(root)
    manifest = json.loads(path.read_text())
    assert manifest["producer"] == mf.KITCHEN
    manifest.update(producer=OLD_PRODUCER, config_class=OLD_CONFIG_CLASS)
    path.write_text(json.dumps(manifest, indent=1) + "\n")

    loaded = mf.load_manifest(root)
    assert loaded["producer"] == mf.KITCHEN
    cfg = GenerationConfig(scene=SceneConfig(configs_per_scene=2), views=ViewConfig(episodes=2))
    assert mf.generation_config(loaded) == cfg
    assert main(["check", str(root)]) == 0

    shard = next((root / "scenes").glob("*.h5"))
    before = shard.read_bytes()
    # Resuming with the same producer and config is accepted and keeps the shard.
    generate_dataset(
        GenerateRequest(out=root, num_scenes=1),
        scene_records,
        cfg,
        progress=False,
        write_card=False,
    )
    assert shard.read_bytes() == before
    assert json.loads(path.read_text())["producer"] == mf.KITCHEN
