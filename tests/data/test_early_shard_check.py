"""`evaluate` and `train` check every shard they will read before any work: a missing,
truncated, foreign or (by its checksum) damaged shard is one line naming it (no HDF5
text), and no model runs."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from dataset_helpers import make_dataset

from momakitchen.cli.main import main
from momakitchen.data.integrity import check_shard_files
from momakitchen.data.manifest import load_manifest
from momakitchen.errors import MomaError

LAST_TRAIN = "scenes/scene_000004.h5"  # scenes 0-4: scene 0 is the test scene


def _damage(root: Path, how: str) -> None:
    shard = root / LAST_TRAIN
    if how == "missing":
        shard.unlink()
    elif how == "truncated":
        with open(shard, "r+b") as fh:
            fh.truncate(shard.stat().st_size // 2)
    elif how == "foreign":  # another scene's shard under this name, its size recorded
        shutil.copy(root / "scenes" / "scene_000003.h5", shard)
        m = json.loads((root / "manifest.json").read_text())
        m["shards"]["4"]["bytes"] = shard.stat().st_size
        (root / "manifest.json").write_text(json.dumps(m))
    elif how == "flipped":  # one byte in the middle: it still opens, its checksum differs
        raw = bytearray(shard.read_bytes())
        raw[len(raw) // 2] ^= 0x01
        shard.write_bytes(bytes(raw))
    else:  # the same size, but not HDF5 any more
        shard.write_bytes(b"\0" * shard.stat().st_size)


@pytest.fixture
def dataset(tmp_path):
    root = tmp_path / "ds"
    make_dataset(root, scenes=5)
    return root


@pytest.mark.parametrize("how", ["missing", "truncated", "foreign", "zeroed"])
def test_check_shard_files_names_the_bad_shard(dataset, how):
    check_shard_files(dataset, load_manifest(dataset))  # sound: no error
    _damage(dataset, how)
    with pytest.raises(MomaError, match=r"scene_000004\.h5") as info:
        check_shard_files(dataset, load_manifest(dataset))
    assert "\n" not in str(info.value)
    # Only the shards asked for are checked (the test split is sound).
    check_shard_files(dataset, load_manifest(dataset), [0])


@pytest.mark.parametrize("how", ["missing", "truncated", "zeroed", "flipped"])
def test_evaluate_and_train_check_before_any_work(dataset, tiny_run, how, tmp_path, capsys):
    import momakitchen.eval.evaluate as evaluate_module
    import momakitchen.train as train_module

    _damage(dataset, how)

    def no_work(*_args, **_kwargs):
        raise AssertionError("work started on a damaged dataset")

    mp = pytest.MonkeyPatch()
    mp.setattr(evaluate_module, "evaluate", no_work)
    mp.setattr(train_module, "train", no_work)
    try:
        argv = ["evaluate", "--data", str(dataset), "--checkpoint", str(tiny_run)]
        argv += ["--json", str(tmp_path / "e.json"), "--split", "train", "--quiet"]
        train = ["train", "--data", str(dataset), "--model", "navaff"]
        train += ["--out", str(tmp_path / "run"), "--quiet"]
        for command in (argv, train):
            assert main(command) == 2
            err = capsys.readouterr().err.strip()
            assert len(err.splitlines()) == 1 and "scene_000004.h5" in err, err
            assert "HDF5" not in err and "errno" not in err and "momakitchen check" in err
    finally:
        mp.undo()
    assert not (tmp_path / "e.json").exists() and not (tmp_path / "run").exists()


def test_a_flipped_byte_is_found_by_the_checksum_only(dataset):
    """The quick check alone passes a shard with one flipped byte; the checksum finds it."""
    _damage(dataset, "flipped")
    check_shard_files(dataset, load_manifest(dataset))
    with pytest.raises(MomaError, match=r"scene_000004\.h5: checksum differs"):
        check_shard_files(dataset, load_manifest(dataset), verify_hash=True)
