"""scripts/msr_labels.py: closed-loop outcomes binned by the label at each Top-1 point."""

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

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "msr_labels.py"
BINS = (0.0, 0.3, 0.6, 0.9, 1.0 + 1e-9)  # the script's columns after its two label-0 ones


def _msr(data: Path, seed: int) -> tuple[dict, list[float]]:
    """An MSR result of method "m" over the dataset's configurations on view ``seed`` % 2,
    choosing each view's floor point of the highest label; and those labels."""
    (sid, entry), *_ = load_manifest(data)["shards"].items()
    records, labels = [], []
    with SceneShard(data / entry["file"]) as shard:
        for ci in range(2):
            ep = shard.episode(ci, seed % 2)
            xy = base_to_world_xy(ep.floor_xyz[:, :2].astype(np.float64), ep.base_pose)
            j = int(np.argmax(ep.floor_label))
            labels.append(float(ep.floor_label[j]))
            chosen = {"points": [xy[j].round(4).tolist()], "outcomes": [1], "stages": [0]}
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
    files, labels = [], []
    for seed in (0, 1):
        result, chosen = _msr(real_dataset, seed)
        labels += chosen
        path = tmp_path / f"msr-{seed}.json"
        path.write_text(json.dumps(result))
        files.append(f"best={path}")
    res = subprocess.run(
        [sys.executable, str(SCRIPT), "--data", str(real_dataset), "--msr", *files],
        capture_output=True,
        text=True,
    )
    assert res.returncode == 0, res.stderr
    (row,) = [line for line in res.stdout.splitlines() if line.startswith("| best |")]
    cells = row.strip("| \n").split(" | ")[1:]
    counts = [int(m.group(1)) if (m := re.search(r"of (\d+)", c)) else 0 for c in cells]
    positive = np.histogram([v for v in labels if v > 0], bins=BINS)[0].tolist()
    assert sum(counts) == 4  # 2 seeds x 2 configurations, each binned once
    assert counts[2:] == positive  # the ones labelled above 0, by label
