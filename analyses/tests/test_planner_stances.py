"""analyses/planner_stances.py: the labelling's successful stances the planner's floor
plan refuses."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[1] / "planner_stances.py"


def test_counts_follow_the_labels_and_the_floor_plan(real_dataset, monkeypatch):
    monkeypatch.syspath_prepend(str(SCRIPT.parent))
    import planner_stances

    from momakitchen.data.manifest import load_manifest

    shards = load_manifest(real_dataset)["shards"].values()
    successes = [n for s in shards for n in s["successes"]]
    assert sum(successes) > 0  # the premise: something to count
    rows = planner_stances.refused_stances(real_dataset)
    assert sum(r["stances"] for r in rows.values()) == sum(successes)
    assert sum(r["configurations"] for r in rows.values()) == sum(n > 0 for n in successes)
    assert all(0 <= r["refused"] <= r["stances"] for r in rows.values())
    # a floor plan that fits no base refuses every stance of every configuration
    monkeypatch.setattr(
        planner_stances, "base_fits", lambda layout, cfg, pts, fp: pts[:, 0] != pts[:, 0]
    )
    for none in planner_stances.refused_stances(real_dataset).values():
        assert none["refused"] == none["stances"] and none["none_left"] == none["configurations"]


def test_not_a_dataset_is_one_line(tmp_path):
    out = subprocess.run(
        [sys.executable, str(SCRIPT), "--data", str(tmp_path)], capture_output=True, text=True
    )
    assert out.returncode == 2
    assert "not a momakitchen dataset" in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1
