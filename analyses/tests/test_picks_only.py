"""analyses/picks_only.py: the dexterity weight for picks only, from a weighted and an
unweighted run."""

from __future__ import annotations

import gzip
import json
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "picks_only.py"
TARGETS = ["fruit", "fridge/door", "cabinet/drawer", "bottle"]


def _msr(path: Path, rows: dict[str, list[int]], targets: list[str] = TARGETS) -> str:
    records = [
        {
            "scene_id": 5,
            "config_index": i,
            "target": t,
            "methods": {m: {"outcomes": [o[i]]} for m, o in rows.items()},
        }
        for i, t in enumerate(targets)
    ]
    path.write_bytes(gzip.compress(json.dumps({"config": {}, "records": records}).encode()))
    return str(path)


def _approach(path: Path, rows: dict[tuple[str, str], list[int]]) -> str:
    records = [
        {
            "scene_id": 5,
            "config_index": i,
            "target": TARGETS[i],
            "start": "far",
            "method": m,
            "policy": p,
            "success": s,
        }
        for (m, p), outcomes in rows.items()
        for i, s in enumerate(outcomes)
    ]
    path.write_text(json.dumps({"config": {}, "records": records}))
    return str(path)


def _script(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, str(SCRIPT), *args], capture_output=True, text=True, check=False
    )


def test_the_openings_take_the_unweighted_runs_outcome(tmp_path):
    sys.path.insert(0, str(SCRIPT.parent))
    import picks_only

    # the weight wins both picks and loses both openings
    w = _msr(tmp_path / "w.json.gz", {"m": [1, 0, 0, 1]})
    u = _msr(tmp_path / "u.json.gz", {"m": [0, 1, 1, 0], "oracle": [1, 1, 1, 1]})
    base = _msr(tmp_path / "b.json.gz", {"oracle": [1, 1, 1, 1], "random": [0, 0, 0, 0]})
    rows = picks_only.table(
        picks_only.outcomes(w, ("m",))["m"],
        picks_only.outcomes(u, ("m",))["m"],
        picks_only.outcomes(base, picks_only.BASELINES),
    )
    assert rows == [
        {
            "policy": "top1",
            "configurations": 4,
            "openings": 2,
            "weighted": 2,
            "unweighted": 2,
            "picks_only": 4,
            "oracle": 4,
            "random": 0,
            "weighted_gap": 0.5,
            "unweighted_gap": 0.5,
            "picks_only_gap": 1.0,
            "check": {"gap": 0.0, "interval": [0.0, 0.0], "verdict": "serves"},
        }
    ]
    # the driven track: per policy, the same rule
    a = _approach(
        tmp_path / "a.json", {("m", "single"): [1, 0, 0, 0], ("m", "uncertain"): [1, 1, 0, 1]}
    )
    b = _approach(
        tmp_path / "b.json", {("n", "single"): [0, 1, 1, 1], ("n", "uncertain"): [0, 0, 0, 0]}
    )
    out = _script(f"{a}:m", f"{b}:n")
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    assert lines[0].startswith("single: 4 configurations (2 open their target)")
    assert "weighted 25.0 %; unweighted 75.0 %; picks_only 75.0 %" in lines[0]
    assert "weighted 75.0 %; unweighted 0.0 %; picks_only 50.0 %" in lines[1]


def test_bad_input_is_one_line_and_exit_2(tmp_path):
    w = _msr(tmp_path / "w.json.gz", {"m": [1, 0, 0, 1]})
    other = _msr(tmp_path / "o.json.gz", {"m": [1, 0, 0, 1]}, targets=["fruit"] * 4)
    missing = str(tmp_path / "missing.json")
    cases = {
        (f"{w}:m", f"{w}:x"): "has no record of method 'x'",
        (f"{w}:m", f"{other}:m"): "has another target in the two runs",
        (f"{w}:m", missing): "give the model's method as FILE:METHOD",
        (f"{w}:m", f"{missing}:m"): "missing.json",
    }
    for (first, second), message in cases.items():
        out = _script(first, second)
        assert out.returncode == 2, (message, out.stderr)
        assert message in out.stderr and len(out.stderr.strip().splitlines()) == 1, out.stderr


@pytest.mark.parametrize("baselines", [None, "only-oracle"])
def test_baselines_must_cover_every_configuration(tmp_path, baselines):
    w = _msr(tmp_path / "w.json.gz", {"m": [1, 0, 0, 1]})
    u = _msr(tmp_path / "u.json.gz", {"m": [0, 1, 1, 0]})
    args = [f"{w}:m", f"{u}:m"]
    if baselines:
        args += ["--baselines", _msr(tmp_path / "b.json.gz", {"oracle": [1, 1, 1, 1]})]
    out = _script(*args)
    if baselines:
        assert out.returncode == 2 and "has no record of method 'random'" in out.stderr
    else:
        assert out.returncode == 0 and "picks_only 100.0 %" in out.stdout


def test_the_composed_drive_pools_with_measured_runs(tmp_path):
    a = _approach(tmp_path / "a.json", {("m", "single"): [1, 0, 0, 0]})
    b = _approach(tmp_path / "b.json", {("n", "single"): [0, 1, 1, 1]})
    out = _script(f"{a}:m", f"{b}:n", "--json", str(tmp_path / "c.json"))
    assert out.returncode == 0, out.stderr
    composed = json.loads((tmp_path / "c.json").read_text())
    assert composed["config"] == {} and composed["composed_from"] == [f"{a}:m", f"{b}:n"]
    assert [(r["method"], r["success"]) for r in composed["records"]] == [
        ("picks_only", 1),  # fruit: the weighted run's
        ("picks_only", 1),  # fridge/door: the unweighted run's
        ("picks_only", 1),
        ("picks_only", 0),  # bottle: the weighted run's
    ]
    out = _script(f"{a}:x", f"{b}:n", "--json", str(tmp_path / "d.json"))
    assert out.returncode == 2 and "holds no approach record of method 'x'" in out.stderr
    assert not (tmp_path / "d.json").exists()
