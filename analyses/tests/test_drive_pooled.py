"""analyses/drive_pooled.py: the driven track pooled over runs of other kitchens."""

from __future__ import annotations

import gzip
import json
import subprocess
import sys
from pathlib import Path

import pytest

from momakitchen.errors import MomaError
from momakitchen.eval.robot_check import gap_closed_interval

SCRIPT = Path(__file__).resolve().parents[1] / "drive_pooled.py"
SETTINGS = {"perception": "realistic", "seed": 0, "map": "static", "part": [1, 1]}


def _run(path: Path, scene: int, rows: dict[tuple[str, str], list[int]], **config) -> str:
    """An approach result of ``scene``'s configurations 0..n-1 (one row list per method and
    policy), gzipped as the archive keeps them."""
    records = [
        {
            "scene_id": scene,
            "config_index": i,
            "method": m,
            "policy": p,
            "success": s,
            "stage": "" if s else "out_of_reach",
        }
        for (m, p), outcomes in rows.items()
        for i, s in enumerate(outcomes)
    ]
    result = {"config": {**SETTINGS, **config}, "records": records}
    path.write_bytes(gzip.compress(json.dumps(result).encode()))
    return str(path)


@pytest.fixture
def drive(monkeypatch):
    monkeypatch.syspath_prepend(str(SCRIPT.parent))
    import drive_pooled

    return drive_pooled


def test_runs_of_other_kitchens_pool_by_configuration(drive, tmp_path):
    first = {("navaff", "uncertain"): [1, 1, 0, 1], ("navaff", "single"): [1, 0, 0, 0]}
    gated = {
        ("navaff", "single"): [0, 0, 0, 0],
        ("oracle", "-"): [1, 1, 1, 0],
        ("random", "-"): [0, 0, 0, 0],
    }
    second = {
        ("body", "uncertain"): [1, 0, 1],
        ("oracle", "-"): [1, 1, 1],
        ("random", "-"): [0, 0, 0],
    }
    args = [
        _run(tmp_path / "a.json.gz", 1, first),
        _run(tmp_path / "b.json.gz", 1, gated) + ":oracle,random",  # not its navaff
        _run(tmp_path / "c.json.gz", 2, second, policies=["single"], part=[2, 2]),
    ]
    table = drive.rows(drive.pooled([drive.read_run(a) for a in args]))
    pooled = {(r["policy"], r["run"]): r for r in table}
    row = pooled[("uncertain", "all")]
    model, oracle, random = [1, 1, 0, 1, 1, 0, 1], [1, 1, 1, 0, 1, 1, 1], [0, 0, 0, 0, 0, 0, 0]
    assert row["episodes"] == 7 and row["success"] == pytest.approx(5 / 7)
    assert row["gap_closed"] == pytest.approx((5 / 7) / (6 / 7))
    low, high = row["gap_closed_95"]
    assert (low, high) == gap_closed_interval(model, oracle, random) and low < 5 / 6 < high
    assert row["misses"] == {"out_of_reach": 2}
    # each run alone, and the single look only where it was driven (the first kitchen)
    assert pooled[("uncertain", str(tmp_path / "c.json.gz"))]["episodes"] == 3
    assert pooled[("single", "all")]["episodes"] == 4
    assert pooled[("single", "all")]["success"] == pytest.approx(1 / 4)


def test_runs_that_do_not_pool_are_one_line(drive, tmp_path):
    model = {("navaff", "uncertain"): [1, 0]}
    base = {("oracle", "-"): [1, 1], ("random", "-"): [0, 0]}
    a = _run(tmp_path / "a.json.gz", 1, {**model, **base})
    for bad, why in [
        ([a, _run(tmp_path / "b.json.gz", 1, model)], "in two runs"),
        ([a, _run(tmp_path / "c.json.gz", 2, model, perception="ideal")], "perception"),
        (
            [_run(tmp_path / "d.json.gz", 1, {**model, ("ring", "single"): [1, 1], **base})],
            "several models",
        ),
        ([a + ":nearest"], "no method 'nearest'"),
        ([_run(tmp_path / "e.json.gz", 1, model)], "no oracle rows"),
    ]:
        with pytest.raises(MomaError, match=why):
            drive.pooled([drive.read_run(x) for x in bad])
    (tmp_path / "f.json").write_text("[]")
    out = subprocess.run(
        [sys.executable, str(SCRIPT), str(tmp_path / "f.json")], capture_output=True, text=True
    )
    assert out.returncode == 2
    assert out.stderr.startswith("drive_pooled.py: error: ") and out.stderr.count("\n") == 1
