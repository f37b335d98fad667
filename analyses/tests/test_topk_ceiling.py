"""analyses/topk_ceiling.py: how high Top-k MSR can go on a dataset's grid trials."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np

from momakitchen.data.manifest import load_manifest
from momakitchen.data.shard import SceneShard

SCRIPT = Path(__file__).resolve().parents[1] / "topk_ceiling.py"


def _run(data: Path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, SCRIPT, "--data", data, *args], capture_output=True, text=True
    )


def _ceilings(out: str) -> tuple[float, float]:
    m = re.search(r"Top-1 ceiling ([\d.]+), Top-\d+ ceiling ([\d.]+)", out)
    assert m, out
    return float(m[1]), float(m[2])


def _test_successes(data: Path) -> np.ndarray:
    """Successful grid trials per test configuration."""
    manifest = load_manifest(data)
    counts = []
    for sid in manifest["splits"]["test"]:
        with SceneShard(data / manifest["shards"][str(sid)]["file"]) as shard:
            for c in range(shard.num_configurations):
                counts.append(int(shard.configuration(c).trial_outcomes.sum()))
    return np.array(counts)


def test_ceilings_match_the_grid_trials(small_dataset):
    n = _test_successes(small_dataset)
    assert (n > 0).any()
    # No spread: every successful trial counts, up to k.
    run = _run(small_dataset, "--spread", "0")
    assert run.returncode == 0, run.stderr
    top1, top5 = _ceilings(run.stdout)
    assert top1 == round(float(np.mean(n > 0)), 3)
    assert top5 == round(float(np.mean(np.minimum(n, 5) / 5)), 3)
    # A spread can only lower Top-k; Top-1 is the feasible share whatever the spread.
    run = _run(small_dataset, "--spread", "0.5")
    assert run.returncode == 0, run.stderr
    spread_top1, spread_top5 = _ceilings(run.stdout)
    assert spread_top1 == top1 and spread_top5 <= top5


def test_bad_input_is_one_line_and_exit_2(small_dataset, tmp_path):
    run = _run(small_dataset, "--top-k", "0")
    assert run.returncode == 2 and run.stderr.count("\n") == 1
    assert "--top-k >= 1" in run.stderr and "got 0" in run.stderr
    run = _run(tmp_path)
    assert run.returncode == 2 and "no manifest.json" in run.stderr
