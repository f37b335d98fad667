"""Scene splits and per-robot coverage."""

from __future__ import annotations

from dataset_helpers import make_dataset

from momakitchen.data.manifest import SPLIT_BLOCK, scene_split
from momakitchen.data.synthetic_scene import SyntheticSceneConfig
from momakitchen.robots.spec import ROBOTS


def test_split_is_deterministic_and_80_20():
    splits = [scene_split(s) for s in range(1000)]
    assert splits == [scene_split(s) for s in range(1000)]
    assert splits.count("test") == 200
    for block in range(0, 1000, SPLIT_BLOCK):  # exactly one test scene per block
        assert splits[block:block + SPLIT_BLOCK].count("test") == 1
    assert len({splits[i:i + SPLIT_BLOCK].index("test") for i in range(0, 1000, 5)}) == 5


def test_all_six_robots_in_both_splits_for_20_scenes(tmp_path):
    # 10 configurations per scene, robots assigned as SceneConfig does.
    cfg = SyntheticSceneConfig(configs_per_scene=10, episodes_per_config=1, image_size=(4, 4),
                               num_global=16, num_floor=8)
    m = make_dataset(tmp_path / "ds", scenes=20, config=cfg)
    assert m["counts"]["test"]["scenes"] == 4 and m["counts"]["train"]["scenes"] == 16
    for split in ("train", "test"):
        present = {r for r, row in m["counts"]["robots"].items() if row[split].get("episodes")}
        assert present == set(ROBOTS) - {n for n in ROBOTS if n.startswith("user")}, split
