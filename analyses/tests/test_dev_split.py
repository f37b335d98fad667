"""analyses/dev_split.py: a tuning view of a dataset that never holds its test scenes."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from momakitchen.data import EpisodeDataset
from momakitchen.data.manifest import load_manifest

SCRIPT = Path(__file__).resolve().parents[1] / "dev_split.py"


def test_dev_view_holds_out_train_scenes_only(small_dataset, tmp_path):
    source = load_manifest(small_dataset)
    out = tmp_path / "dev"
    run = subprocess.run(
        [sys.executable, SCRIPT, "--data", small_dataset, "--out", out, "--every", "2"],
        capture_output=True,
        text=True,
    )
    assert run.returncode == 0, run.stderr
    dev = load_manifest(out)
    train = source["splits"]["train"]
    assert dev["splits"]["test"] == train[::2]
    assert dev["splits"]["train"] == [s for s in train if s not in train[::2]]
    assert not set(source["splits"]["test"]) & {int(k) for k in dev["shards"]}
    held = EpisodeDataset(out, "test")
    assert {key[1] for key in held.index} == set(train[::2])
    assert held[0]["floor_label"].shape[0] > 0  # the shards are read through the link
    assert dev["counts"]["total"]["episodes"] == source["counts"]["train"]["episodes"]


def test_bad_every_is_one_line_and_exit_2(small_dataset, tmp_path):
    run = subprocess.run(
        [sys.executable, SCRIPT, "--data", small_dataset, "--out", tmp_path / "d", "--every", "1"],
        capture_output=True,
        text=True,
    )
    assert run.returncode == 2
    assert run.stderr.strip() == "dev_split.py: error: --every must be >= 2, got 1"
    assert not (tmp_path / "d").exists()


def test_train_scenes_keeps_the_first_of_the_rest_and_the_same_held_out(small_dataset, tmp_path):
    train = load_manifest(small_dataset)["splits"]["train"]
    rest = [s for s in train if s not in train[::2]]
    out = tmp_path / "dev1"
    args = ["--data", small_dataset, "--out", out, "--every", "2", "--train-scenes", "1"]
    run = subprocess.run([sys.executable, SCRIPT, *args], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    dev = load_manifest(out)
    assert dev["splits"]["train"] == rest[:1]
    assert dev["splits"]["test"] == train[::2]
    assert "the first 1 of the others" in dev["split_rule"]


def test_too_many_train_scenes_is_one_line_and_exit_2(small_dataset, tmp_path):
    train = load_manifest(small_dataset)["splits"]["train"]
    n = len(train) - len(train[::2])
    args = ["--data", small_dataset, "--out", tmp_path / "d", "--every", "2"]
    run = subprocess.run(
        [sys.executable, SCRIPT, *args, "--train-scenes", str(n + 1)],
        capture_output=True,
        text=True,
    )
    assert run.returncode == 2
    assert run.stderr.strip() == (
        f"dev_split.py: error: --train-scenes {n + 1}: the view has only {n} train scenes"
    )
    assert not (tmp_path / "d").exists()
