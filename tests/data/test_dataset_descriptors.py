"""Data stored with an older robot descriptor: read as the current one (each episode's
descriptor gains its robot's finger force), checked, and never extended by `generate`."""

from __future__ import annotations

import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest
from dataset_helpers import make_dataset

from momakitchen.data import manifest as mf
from momakitchen.data.integrity import check_dataset
from momakitchen.data.shard import SceneShard, file_sha256
from momakitchen.data.torch_dataset import EpisodeDataset
from momakitchen.errors import MomaError
from momakitchen.fileio import dumps_strict
from momakitchen.robots.spec import DESCRIPTOR_DIM, DESCRIPTOR_LAYOUTS, DESCRIPTOR_VERSION


def _as_version_1(root: Path) -> None:
    """Rewrite a dataset as a version-1 writer stored it: four descriptor columns, the
    version and names in every shard and the manifest (sizes and checksums updated)."""
    manifest = mf.load_manifest(root)
    names = list(DESCRIPTOR_LAYOUTS[1])
    for entry in manifest["shards"].values():
        path = root / entry["file"]
        with h5py.File(path, "r+") as f:
            f.attrs["descriptor_version"] = 1
            f.attrs["descriptor_names"] = dumps_strict(names)
            for c in (k for k in f if k.startswith("config_")):
                for e in (k for k in f[c] if k.startswith("episode_")):
                    old = f[c][e]["descriptor"][()]
                    del f[c][e]["descriptor"]
                    f[c][e]["descriptor"] = old[:4]
        entry["bytes"] = path.stat().st_size
        entry["sha256"] = file_sha256(path)
    manifest["descriptor_version"], manifest["descriptor_names"] = 1, names
    mf.save_manifest(root, manifest)


@pytest.fixture(scope="module")
def both(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The same synthetic dataset as written now and as a version-1 writer wrote it."""
    now = tmp_path_factory.mktemp("desc") / "now"
    make_dataset(now, scenes=3)
    old = now.parent / "old"
    shutil.copytree(now, old)
    _as_version_1(old)
    return now, old


def test_a_version_1_dataset_reads_as_the_current_one(both):
    now, old = both
    new_set, old_set = EpisodeDataset(now, "all"), EpisodeDataset(old, "all")
    assert len(new_set) == len(old_set) > 0
    for i in range(len(new_set)):
        a, b = new_set[i], old_set[i]
        assert b["robot"].shape == (DESCRIPTOR_DIM,)
        assert np.array_equal(a["robot"].numpy(), b["robot"].numpy())
    with SceneShard(next((old / "scenes").iterdir())) as shard:
        assert shard.descriptor_version == 1
        assert shard.arrays(0, 0, ["descriptor"])["descriptor"].shape == (DESCRIPTOR_DIM,)


def test_a_version_1_dataset_passes_its_check(both):
    check_dataset(both[1])


def test_generate_does_not_extend_a_dataset_of_another_version(both):
    old = both[1]
    before = sorted((old / "scenes").iterdir())
    with pytest.raises(MomaError, match=f"descriptor version 1.*writes {DESCRIPTOR_VERSION}"):
        make_dataset(old, scenes=4)
    assert mf.load_manifest(old)["descriptor_version"] == 1  # nothing written
    assert sorted((old / "scenes").iterdir()) == before
    # Asked for the scenes it holds, it has nothing to do (scripts resume finished data).
    assert make_dataset(old, scenes=3)["descriptor_version"] == 1


def test_an_unknown_descriptor_version_is_refused(both, tmp_path):
    root = tmp_path / "future"
    shutil.copytree(both[0], root)
    path = next((root / "scenes").iterdir())
    with h5py.File(path, "r+") as f:
        f.attrs["descriptor_version"] = 99
    with pytest.raises(MomaError, match="robot descriptor version 99, this reader understands"):
        SceneShard(path)
