"""analyses/msr_labels.py: closed-loop outcomes binned by the label at each Top-1 point."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np

from momakitchen.data.manifest import load_manifest
from momakitchen.data.shard import SceneShard
from momakitchen.frames import base_to_world_xy

SCRIPT = Path(__file__).resolve().parents[1] / "msr_labels.py"
BINS = (0.0, 0.3, 0.6, 0.9, 1.0 + 1e-9)  # the script's columns after its two label-0 ones


def _msr(data: Path, seed: int, pick: str, outcomes: list[int]) -> tuple[dict, list[float]]:
    """An MSR result of method "m" over the dataset's two configurations on view ``seed`` % 2,
    choosing each view's floor point of the highest label (``pick="best"``) or the lowest,
    with the given trial outcomes; and the labels at those points."""
    (sid, entry), *_ = load_manifest(data)["shards"].items()
    records, labels = [], []
    with SceneShard(data / entry["file"]) as shard:
        for ci, outcome in enumerate(outcomes):
            ep = shard.episode(ci, seed % 2)
            xy = base_to_world_xy(ep.floor_xyz[:, :2].astype(np.float64), ep.base_pose)
            j = int(np.argmax(ep.floor_label) if pick == "best" else np.argmin(ep.floor_label))
            labels.append(float(ep.floor_label[j]))
            chosen = {"points": [xy[j].round(4).tolist()], "outcomes": [outcome], "stages": [0]}
            records.append(
                {
                    "scene_id": int(sid),
                    "config_index": ci,
                    "episode_index": seed % 2,
                    "robot": ep.robot,
                    "target": "t",
                    "feasible": True,
                    "methods": {"m": chosen},
                }
            )
    config = {"top_k": 1, "min_spread": 0.2, "pick_radius": 0.0, "seed": seed}
    result = {"dataset": str(data), "config": config, "methods": {"m": {}}, "records": records}
    return result, labels


def test_counts_every_view_of_every_seed_in_its_label_bin(real_dataset, tmp_path):
    # Seed 0: each view's best point, both trials succeed; seed 1: its worst point (label 0),
    # one trial fails. Each trial must land in its own label's bin with its own outcome.
    files, labels = [], []
    for seed, pick, outcomes in [(0, "best", [1, 1]), (1, "worst", [0, 1])]:
        result, chosen = _msr(real_dataset, seed, pick, outcomes)
        labels += chosen
        path = tmp_path / f"msr-{seed}.json"
        path.write_text(json.dumps(result))
        files.append(f"picked={path}")
    assert labels[2:] == [0.0, 0.0] and min(labels[:2]) > 0
    res = subprocess.run(
        [sys.executable, str(SCRIPT), "--data", str(real_dataset), "--msr", *files],
        capture_output=True,
        text=True,
    )
    assert res.returncode == 0, res.stderr
    (row,) = [line for line in res.stdout.splitlines() if line.startswith("| picked |")]
    cells = [re.fullmatch(r"(\d+)% of (\d+)|–", c) for c in row.strip("| \n").split(" | ")[1:]]
    counts = [int(m.group(2)) if m.group(2) else 0 for m in cells]
    wins = [round(int(m.group(1)) * int(m.group(2)) / 100) if m.group(2) else 0 for m in cells]
    positive = np.histogram(labels[:2], bins=BINS)[0].tolist()
    assert counts[2:] == positive and wins[2:] == positive  # the best points: all succeeded
    assert sum(counts[:2]) == 2 and sum(wins[:2]) == 1  # label 0: one of two succeeded
