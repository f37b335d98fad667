"""analyses/pcc_feasible.py: map metrics over the views that have something to find."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from momakitchen.data import EpisodeDataset
from momakitchen.metrics import episode_metrics, map_metrics

SCRIPT = Path(__file__).resolve().parents[1] / "pcc_feasible.py"


def test_rescaling_equals_the_metrics_over_the_non_constant_maps(small_dataset, monkeypatch):
    monkeypatch.syspath_prepend(str(SCRIPT.parent))
    from pcc_feasible import ZERO_ON_CONSTANT, constant_maps, rescaled

    data = EpisodeDataset(small_dataset, "all")
    gts = [np.asarray(data[i]["floor_label"], float) for i in range(len(data))]
    gts[0] = np.zeros_like(gts[0])  # at least one view with nothing to find
    constant = np.array([np.ptp(g) == 0 for g in gts])
    assert constant_maps(small_dataset, "all")[1:].tolist() == constant[1:].tolist()
    rng = np.random.default_rng(0)
    preds = [rng.uniform(0, 1, len(g)) for g in gts]
    # the premise: a constant map scores exactly 0 on the four metrics, whatever the guess
    assert all(episode_metrics(preds[0], gts[0])[k] == 0 for k in ZERO_ON_CONSTANT)
    result = {"episodes": len(gts), "metrics": map_metrics(preds, gts)}
    kept = [i for i in range(len(gts)) if not constant[i]]
    over = map_metrics([preds[i] for i in kept], [gts[i] for i in kept])
    got = rescaled(result, constant)
    for k in ZERO_ON_CONSTANT:
        assert got[k] == pytest.approx(over[k], rel=1e-9)


def test_a_result_of_other_data_is_one_line(small_dataset, tmp_path):
    path = tmp_path / "eval.json"
    path.write_text(json.dumps({"split": "all", "episodes": 3, "metrics": {"pcc": 0.5}}))
    cmd = [sys.executable, str(SCRIPT), "--data", str(small_dataset), "--evaluate", str(path)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stderr.startswith("pcc_feasible.py: error: the result scored 3 episodes")
    assert proc.stderr.count("\n") == 1
