"""EpisodeDataset: the batch contract, splits, DataLoader workers, errors."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch
from dataset_helpers import SMALL
from torch.utils.data import DataLoader

from momakitchen.data import EpisodeDataset
from momakitchen.data.batch import EpisodeCollator, validate_sample
from momakitchen.data.generator import GenerateRequest, generate_dataset
from momakitchen.data.integrity import check_dataset, dataset_stats
from momakitchen.data.shard import SceneShard, list_shards
from momakitchen.data.synthetic_scene import synthetic_scene_records
from momakitchen.errors import MomaError
from momakitchen.robots.descriptor import robot_descriptor
from momakitchen.robots.spec import DESCRIPTOR_DIM, ROBOTS


def test_samples_follow_the_contract(small_dataset):
    ds = EpisodeDataset(small_dataset, split="all")
    assert len(ds) == 30
    s = ds[7]
    validate_sample(s)
    assert s["global_rgb"].dtype == torch.float32
    assert 0.0 <= float(s["global_rgb"].min()) and float(s["global_rgb"].max()) <= 1.0
    assert set(np.unique(s["global_align"].numpy())) <= {-1.0, 0.0, 1.0}
    np.testing.assert_allclose(
        s["robot"].numpy(), robot_descriptor(ROBOTS[s["robot_name"]]), rtol=1e-6
    )
    with SceneShard(list_shards(small_dataset)[s["scene_id"]]) as shard:
        ep = shard.episode(s["config_index"], s["episode_index"])
    np.testing.assert_array_equal(s["floor_label"].numpy(), ep.floor_label)
    np.testing.assert_allclose(s["global_rgb"].numpy() * 255, ep.global_rgb, atol=1e-4)


def test_a_sample_says_whether_its_robot_opens_the_target(small_dataset):
    ds = EpisodeDataset(small_dataset, split="all")
    told = {}
    for s in ds:
        with SceneShard(list_shards(small_dataset)[s["scene_id"]]) as shard:
            target = shard.configuration(s["config_index"]).target
        assert s["target_opens"] == ("/" in target), target
        told[s["target_opens"]] = target
    assert set(told) == {True, False}  # both kinds were read


def test_splits_partition_the_scenes(small_dataset):
    train, test = EpisodeDataset(small_dataset, "train"), EpisodeDataset(small_dataset, "test")
    assert len(train) + len(test) == 30 and len(test) > 0
    assert not {i[1] for i in train.index} & {i[1] for i in test.index}
    only = EpisodeDataset(small_dataset, "all", robots=["panda"])
    assert len(only) > 0 and all(i[4] == "panda" for i in only.index)


def test_dataloader_with_two_workers_and_collator(small_dataset):
    ds = EpisodeDataset(small_dataset, split="train")
    loader = DataLoader(
        ds,
        batch_size=4,
        num_workers=2,
        shuffle=False,
        collate_fn=EpisodeCollator(num_global=256, num_floor=200),
    )
    batches = list(loader)
    assert sum(len(b["scene_id"]) for b in batches) == len(ds)
    b = batches[0]
    assert b["global_xyz"].shape == (4, 256, 3) and b["global_rgb"].shape == (4, 256, 3)
    assert b["global_align"].shape == (4, 256) and b["global_mask"].all()  # >= 256 points
    assert b["floor_xyz"].shape == (4, 200, 3) and b["floor_label"].shape == (4, 200)
    assert b["robot"].shape == (4, DESCRIPTOR_DIM)
    assert not b["floor_mask"].all() and b["floor_mask"].any()  # < 200 floor points: padded
    assert b["floor_label"][~b["floor_mask"]].abs().sum() == 0


def test_bad_root_and_split(tmp_path, small_dataset):
    with pytest.raises(MomaError, match="does not exist"):
        EpisodeDataset(tmp_path / "nope")
    with pytest.raises(MomaError, match=r"no manifest\.json"):
        EpisodeDataset(tmp_path)
    with pytest.raises(MomaError, match="split must be one of"):
        EpisodeDataset(small_dataset, split="val")


def _records_with_an_empty_floor(scene_id, config):
    records = synthetic_scene_records(scene_id, config)
    ep = records[0][1][1]
    records[0][1][1] = dataclasses.replace(
        ep, floor_xyz=ep.floor_xyz[:0], floor_label=ep.floor_label[:0]
    )
    return records


def test_episodes_without_floor_points_are_skipped(tmp_path):
    root = tmp_path / "ds"
    generate_dataset(
        GenerateRequest(out=root, num_scenes=1),
        _records_with_an_empty_floor,
        SMALL,
        progress=False,
        write_card=False,
    )
    assert check_dataset(root)["episodes"] == 6  # valid data, counted
    assert dataset_stats(root)["episodes_with_empty_cloud"] == 1
    ds = EpisodeDataset(root, split="all")
    assert len(ds) == 5 and ("scenes/scene_000000.h5", 0, 0, 1) not in {i[:4] for i in ds.index}
    assert len(EpisodeDataset(root, split="all", skip_empty=False)) == 6
    EpisodeCollator()([ds[i] for i in range(len(ds))])  # would raise on an empty cloud


def test_several_datasets_read_as_one(small_dataset):
    """EpisodeDatasets: the parts' episodes in order, and the epoch's draw passed on to
    every part (each draws its sensor noise from it)."""
    from momakitchen.data import EpisodeDatasets

    train, test = EpisodeDataset(small_dataset, "train"), EpisodeDataset(small_dataset, "test")
    both = EpisodeDatasets([train, test])
    assert len(both) == len(train) + len(test)
    first_test = both[len(train)]
    assert (first_test["scene_id"], first_test["config_index"]) == (
        test[0]["scene_id"],
        test[0]["config_index"],
    )
    both.set_epoch(3, seed=5)
    assert [(p.epoch, p.noise_seed) for p in (train, test)] == [(3, 5), (3, 5)]
    with pytest.raises(MomaError, match="sensor noise needs the RGB-D frames"):
        both.use_sensor_noise(None)  # a synthetic dataset has no frames
