"""Scene splits and per-robot coverage."""

from __future__ import annotations

import pytest
from dataset_helpers import make_dataset

from momakitchen.data.manifest import (
    SPLIT_BLOCK,
    generation_config,
    load_manifest,
    scene_split,
    split_checksum,
)
from momakitchen.data.synthetic_scene import SyntheticSceneConfig, synthetic_scene_records
from momakitchen.errors import MomaError
from momakitchen.robots.spec import DEFAULT_ROBOTS, ROBOTS


def test_split_is_deterministic_and_80_20():
    splits = [scene_split(s) for s in range(1000)]
    assert splits == [scene_split(s) for s in range(1000)]
    assert splits.count("test") == 200
    for block in range(0, 1000, SPLIT_BLOCK):  # exactly one test scene per block
        assert splits[block : block + SPLIT_BLOCK].count("test") == 1
    assert len({splits[i : i + SPLIT_BLOCK].index("test") for i in range(0, 1000, 5)}) == 5


def test_all_six_robots_in_both_splits_for_20_scenes(tmp_path):
    # 10 configurations per scene, robots assigned as SceneConfig does.
    cfg = SyntheticSceneConfig(
        configs_per_scene=10, episodes_per_config=1, image_size=(4, 4), num_global=16, num_floor=8
    )
    m = make_dataset(tmp_path / "ds", scenes=20, config=cfg)
    assert m["counts"]["test"]["scenes"] == 4 and m["counts"]["train"]["scenes"] == 16
    for split in ("train", "test"):
        present = {r for r, row in m["counts"]["robots"].items() if row[split].get("episodes")}
        # The paper's six, not the other arms nor any user robot registered by now.
        assert present == set(DEFAULT_ROBOTS), split
    assert {"ur10e", "gen3"} <= set(ROBOTS) and not {"ur10e", "gen3"} & set(DEFAULT_ROBOTS)


def test_synthetic_robot_assignment_is_the_scene_samplers():
    from momakitchen.scene.configuration import SceneConfig, sample_scene

    cfg = SyntheticSceneConfig(
        configs_per_scene=10, episodes_per_config=1, image_size=(4, 4), num_global=16, num_floor=8
    )
    real = [c.robot for c in sample_scene(3, SceneConfig()).configurations]
    assert [lab.robot for lab, _ in synthetic_scene_records(3, cfg)] == real
    assert len(set(real)) == 6


def test_generation_config_is_rebuilt_from_the_manifest(small_dataset):
    from dataset_helpers import SMALL

    assert generation_config(load_manifest(small_dataset)) == SMALL


def test_split_checksum_names_the_splits_shard_bytes(small_dataset):
    manifest = load_manifest(small_dataset)
    test = split_checksum(manifest, "test")
    assert test == split_checksum(load_manifest(small_dataset), "test") and len(test) == 64
    assert test != split_checksum(manifest, "train")

    def changed(split: str) -> dict:
        shards = {k: dict(e) for k, e in manifest["shards"].items()}
        key = next(k for k, e in shards.items() if e["split"] == split)
        shards[key]["sha256"] = "0" * 64
        return {**manifest, "shards": shards}

    assert split_checksum(changed("test"), "test") != test  # another test shard's bytes
    assert split_checksum(changed("train"), "test") == test  # train shards play no part
    with pytest.raises(MomaError, match="unknown split 'val'"):
        split_checksum(manifest, "val")
