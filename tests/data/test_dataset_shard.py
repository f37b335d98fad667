"""Scene shards: exact round trip, reproducible bytes, atomicity and rejection of bad files."""

from __future__ import annotations

import dataclasses

import h5py
import numpy as np
import pytest

from momakitchen.data.shard import (
    SCHEMA_VERSION,
    SceneShard,
    file_sha256,
    list_shards,
    remove_temporaries,
    shard_name,
    write_shard,
)
from momakitchen.data.synthetic_scene import SyntheticSceneConfig, synthetic_scene_records
from momakitchen.errors import MomaError

CFG = SyntheticSceneConfig(configs_per_scene=2, episodes_per_config=2)


def _assert_fields_equal(a, b, same_array) -> None:
    for f in dataclasses.fields(a):
        va, vb = getattr(a, f.name), getattr(b, f.name)
        if isinstance(va, np.ndarray):
            assert same_array(va, vb) and np.array_equal(va, vb), f.name
        else:
            assert va == vb, f.name


def _assert_records_equal(a, b) -> None:
    assert len(a) == len(b)
    for (la, ea), (lb, eb) in zip(a, b, strict=True):
        _assert_fields_equal(la, lb, lambda x, y: x.dtype == y.dtype)
        assert len(ea) == len(eb)
        for x, y in zip(ea, eb, strict=True):
            _assert_fields_equal(x, y, lambda u, v: u.shape == v.shape)


def test_round_trip_is_exact_and_bytes_reproducible(tmp_path):
    records = synthetic_scene_records(12, CFG)
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    sa = write_shard(tmp_path / "a", 12, records)
    sb = write_shard(tmp_path / "b", 12, synthetic_scene_records(12, CFG))
    assert sa["sha256"] == sb["sha256"] == file_sha256(tmp_path / "a" / shard_name(12))
    assert sa["episodes_per_config"] == [2, 2] and sa["file"] == "scenes/scene_000012.h5"
    with SceneShard(tmp_path / "a" / shard_name(12)) as shard:
        assert shard.scene_id == 12 and shard.num_episodes == 4
        back = shard.records()
        assert back[0][1][0].global_rgb.dtype == np.uint8
    _assert_records_equal(records, back)
    with h5py.File(tmp_path / "a" / shard_name(12), "r") as f:
        assert f.attrs["schema_version"] == SCHEMA_VERSION
        assert f["config_001/episode_001/rgb"].compression == "gzip"


def test_incomplete_and_truncated_shards_are_rejected(tmp_path):
    write_shard(tmp_path, 3, synthetic_scene_records(3, CFG))
    path = tmp_path / shard_name(3)
    # A file whose completion mark is missing (a writer that died before the end).
    with h5py.File(path, "a") as f:
        del f.attrs["complete"]
    with pytest.raises(MomaError, match="incomplete"):
        SceneShard(path)
    write_shard(tmp_path, 4, synthetic_scene_records(4, CFG))
    data = (tmp_path / shard_name(4)).read_bytes()
    (tmp_path / shard_name(4)).write_bytes(data[: len(data) // 2])
    with pytest.raises(MomaError, match=r"scene_000004\.h5: cannot open"):
        SceneShard(tmp_path / shard_name(4))


def test_temporaries_are_never_listed_and_get_removed(tmp_path):
    scenes = tmp_path / "scenes"
    scenes.mkdir()
    write_shard(scenes, 1, synthetic_scene_records(1, CFG))
    (scenes / ".tmp-999-scene_000002.h5").write_bytes(b"partial")
    (scenes / ".scene_000005.123.tmp.h5").write_bytes(b"partial")
    assert list(list_shards(tmp_path)) == [1]
    removed = remove_temporaries(tmp_path)
    assert len(removed) == 2 and sorted(p.name for p in scenes.iterdir()) == ["scene_000001.h5"]


def test_writer_refuses_mislabelled_records(tmp_path):
    records = synthetic_scene_records(1, CFG)
    with pytest.raises(MomaError, match="scene 2"):
        write_shard(tmp_path, 2, records)
    assert not list(tmp_path.iterdir())  # nothing left behind


def test_infeasible_configurations_are_flagged_and_counted(tmp_path):
    """A configuration without a successful trial stays in the data, flagged in the shard
    and the manifest entry, and counted; views are counted as covering only where their
    floor comes within 10 cm of a success."""
    from momakitchen.data import manifest as mf
    from momakitchen.data.shard import COVERAGE_RADIUS, sees_success

    records = synthetic_scene_records(3, CFG)
    lab0, eps0 = records[0]
    failed = dataclasses.replace(lab0, trial_stages=np.full_like(lab0.trial_stages, 5))
    records = [(failed, eps0), records[1]]
    assert records[1][0].feasible and not failed.feasible
    summary = write_shard(tmp_path, 3, records)
    assert summary["feasible"] == [False, True]
    with h5py.File(tmp_path / shard_name(3), "r") as f:
        assert [int(f[f"config_00{c}"].attrs["feasible"]) for c in (0, 1)] == [0, 1]
    lab1, eps1 = records[1]
    expected = sum(sees_success(lab1, e.floor_xyz, e.base_pose) for e in eps1)
    assert summary["covering_views"] == [0, expected]
    with SceneShard(tmp_path / shard_name(3)) as shard:
        assert shard.covering_views(1) == expected
    counts = mf.compute_counts([{**summary, "split": "test"}])
    assert counts["total"]["infeasible_configurations"] == 1
    assert counts["total"]["feasible_views"] == len(eps1)
    assert counts["total"]["covering_views"] == expected
    # The radius is what the counts say: a floor point just inside covers, just outside not.
    success = lab1.trial_positions[lab1.trial_stages == 0][:1]
    only = dataclasses.replace(lab1, trial_positions=success, trial_stages=np.zeros(1, np.uint8))
    base = (0.0, 0.0, 0.0)
    near = np.array([[success[0, 0] + COVERAGE_RADIUS - 1e-3, success[0, 1], 0.0]])
    far = np.array([[success[0, 0] + COVERAGE_RADIUS + 1e-3, success[0, 1], 0.0]])
    assert sees_success(only, near, base) and not sees_success(only, far, base)
