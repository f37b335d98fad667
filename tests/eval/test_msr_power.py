"""scripts/msr_power.py: the power of McNemar's test on a set of MSR configurations."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

SCRIPTS = Path(__file__).resolve().parents[2] / "scripts"


def _msr(outcomes: dict[str, list[int]]) -> dict:
    """A `momakitchen msr` result with one Top-1 outcome per configuration and method."""
    n = len(next(iter(outcomes.values())))
    records = [
        {
            "scene_id": 7,
            "config_index": c,
            "episode_index": 0,
            "robot": "ur5e",
            "target": "cabinet/door",
            "feasible": True,
            "methods": {m: {"outcomes": [o[c]]} for m, o in outcomes.items()},
        }
        for c in range(n)
    ]
    config = {"top_k": 1, "min_spread": 0.2, "pick_radius": 0.0, "seed": 0}
    return {
        "dataset": "/data",
        "config": config,
        "methods": {m: {} for m in outcomes},
        "records": records,
    }


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, str(SCRIPTS / "msr_power.py"), *args], capture_output=True, text=True
    )


def test_reports_power_and_configurations_needed(tmp_path):
    # 200 configurations: 12 only a, 4 only b (discordant 8 %, lead 4 points), 184 agree.
    a = [1] * 12 + [0] * 4 + [1] * 150 + [0] * 34
    b = [0] * 12 + [1] * 4 + [1] * 150 + [0] * 34
    path = tmp_path / "msr.json"
    path.write_text(json.dumps(_msr({"a": a, "b": b})))
    res = _run("--msr", str(path), "--reference", "a", "--other", "b")
    assert res.returncode == 0, res.stderr
    assert "only a 12, only b 4 (discordant 8.0 %), McNemar p = 0.077" in res.stdout
    need = int(re.search(r"needs (\d+) configurations", res.stdout).group(1))
    assert 200 < need < 2000  # p = 0.077 on 200: somewhat more are needed
    found = float(re.search(r"power on 200 configurations: ([\d.]+) points", res.stdout).group(1))
    assert 4.0 < found <= 8.0  # more than the measured lead, at most the discordant rate

    res = _run("--msr", str(path), "--reference", "b", "--other", "a")
    assert "not ahead" in res.stdout


def test_bad_input_is_one_line_and_exit_2(tmp_path):
    path = tmp_path / "msr.json"
    path.write_text(json.dumps(_msr({"a": [1, 0], "b": [0, 1]})))
    for args, message in [
        (["--other", "c"], "method 'c'"),
        (["--other", "b", "--power", "1"], "--power"),
        (["--other", "b", "--msr", str(tmp_path / "nope.json")], "nope.json"),
    ]:
        res = _run("--msr", str(path), "--reference", "a", *args)
        assert res.returncode == 2, res.stderr
        assert len(res.stderr.strip().splitlines()) == 1 and message in res.stderr
