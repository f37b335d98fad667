"""scripts/run_compare.py: two trainings of one model compared per scene and per
configuration."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

SCRIPTS = Path(__file__).resolve().parents[2] / "scripts"


def _run(tmp: Path, name: str, pcc: list[float], top1: list[int]) -> Path:
    """A run directory with a test.json (per-scene PCC) and a one-method msr.json."""
    run = tmp / name
    run.mkdir()
    scenes = {str(s): {"pcc": p, "sim": p, "rmse": 1 - p, "ciou": p} for s, p in enumerate(pcc)}
    (run / "test.json").write_text(json.dumps({"model": "pointnet2", "per_scene": scenes}))
    records = [
        {
            "scene_id": 0,
            "config_index": c,
            "episode_index": c,
            "robot": "franka",
            "target": "cup",
            "feasible": True,
            "methods": {"pointnet2": {"outcomes": [o]}},
        }
        for c, o in enumerate(top1)
    ]
    msr = {"dataset": "d", "config": {}, "methods": {"pointnet2": {}}, "records": records}
    (run / "msr.json").write_text(json.dumps(msr))
    return run


def _compare(*args: str) -> subprocess.CompletedProcess:
    cmd = [sys.executable, str(SCRIPTS / "run_compare.py"), *args]
    return subprocess.run(cmd, capture_output=True, text=True, check=False)


def test_pairs_scenes_and_configurations(tmp_path):
    a = _run(tmp_path, "a", [0.8] * 10, [1] * 6 + [0] * 4)
    b = _run(tmp_path, "b", [0.7] * 9 + [0.9], [0] * 6 + [0] * 4)
    out = _compare(f"new={a}", f"old={b}")
    assert out.returncode == 0, out.stderr
    # new is better in 9 of 10 scenes; only new solves 6 configurations, old none.
    assert "| old | 9 of 10," in out.stdout
    assert "| old | 6 | 0 |" in out.stdout


def test_bad_input_is_one_line_and_status_2(tmp_path):
    a = _run(tmp_path, "a", [0.8] * 3, [1, 0, 1])
    out = _compare(f"new={a}", f"old={tmp_path / 'missing'}")
    assert out.returncode == 2
    assert out.stderr.strip().count("\n") == 0 and "missing" in out.stderr
    out = _compare(f"new={a}")
    assert out.returncode == 2 and "NAME=RUN" in out.stderr
