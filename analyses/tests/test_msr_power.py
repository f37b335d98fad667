"""analyses/msr_power.py: the power of McNemar's test on a set of MSR configurations."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from momakitchen.errors import MomaError

ANALYSES = Path(__file__).resolve().parents[1]


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
        [sys.executable, str(ANALYSES / "msr_power.py"), *args], capture_output=True, text=True
    )


@pytest.fixture()
def power_main(monkeypatch):
    """The script's main(argv), imported (its imports need the analyses folder on the path)."""
    monkeypatch.syspath_prepend(str(ANALYSES))
    from msr_power import main

    return main


def test_reports_power_and_configurations_needed(tmp_path):
    from momakitchen.eval.stats import configurations_needed, detectable_lead, mcnemar_power

    # 200 configurations: 12 only a, 4 only b (discordant 8 %, lead 4 points), 184 agree.
    a = [1] * 12 + [0] * 4 + [1] * 150 + [0] * 34
    b = [0] * 12 + [1] * 4 + [1] * 150 + [0] * 34
    path = tmp_path / "msr.json"
    path.write_text(json.dumps(_msr({"a": a, "b": b})))
    res = _run("--msr", str(path), "--reference", "a", "--other", "b")
    assert res.returncode == 0, res.stderr
    first, second, third = res.stdout.splitlines()
    assert "only a 12, only b 4 (discordant 8.0 %), McNemar p = 0.077" in first
    power, need = mcnemar_power(200, 0.08, 0.04), configurations_needed(0.08, 0.04, 0.8)
    assert second == (
        f"measured lead +4.0 points: power {100 * power:.0f} % on 200 configurations; "
        f"80 % power needs {need} configurations ({need / 200:.1f}x)"
    )
    assert 200 < need  # p = 0.077 on 200: more are needed
    lead = detectable_lead(200, 0.08, 0.8)
    assert third.endswith(f"on 200 configurations: {100 * lead:.1f} points")

    res = _run("--msr", str(path), "--reference", "b", "--other", "a")
    assert res.returncode == 0, res.stderr
    assert "-4.0 points: not ahead" in res.stdout

    res = _run("--msr", str(path), "--reference", "a", "--other", "b", "--lead", "0.08")
    assert res.returncode == 0, res.stderr
    assert "planned lead +8.0 points: power" in res.stdout


def test_bad_input_is_one_line_and_exit_2(tmp_path, power_main):
    path = tmp_path / "msr.json"
    path.write_text(json.dumps(_msr({"a": [1, 0], "b": [0, 1], "c": [1, 0]})))
    res = _run("--msr", str(path), "--reference", "a", "--other", "d")
    assert res.returncode == 2 and res.stdout == ""
    assert res.stderr.strip() == (
        "msr_power.py: error: method 'd' is not in the MSR results: ['a', 'b', 'c']"
    )
    for args, message in [
        (["--other", "b", "--power", "1"], "--power 1"),
        (["--other", "b", "--alpha", "0"], "--alpha 0"),
        (["--other", "b", "--lead", "nan"], "--lead must"),
        (["--other", "b", "--lead", "2"], "got 2.0"),
        (["--other", "a"], "both 'a'"),
        (["--other", "c"], "agree on every configuration"),
        (["--other", "b", "--msr", str(tmp_path / "nope.json")], "nope.json"),
    ]:
        with pytest.raises(MomaError, match=re.escape(message)):
            power_main(["--msr", str(path), "--reference", "a", *args])
