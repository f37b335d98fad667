"""analyses/msr_views.py: closed-loop success pooled over several views per configuration."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[1] / "msr_views.py"


def _result(seed: int, outcomes: dict[str, list[int]], top_k: int = 1) -> dict:
    """A `momakitchen msr` result of len(outcomes[m]) configurations (views chosen by
    ``seed``)."""
    n = len(next(iter(outcomes.values())))
    return {
        "dataset": "/data",
        "config": {"top_k": top_k, "min_spread": 0.2, "pick_radius": 0.0, "seed": seed},
        "methods": {m: {} for m in outcomes},
        "records": [
            {
                "scene_id": 7,
                "config_index": c,
                "episode_index": (seed + c) % 3,
                "robot": "ur5e",
                "target": "cabinet/door",
                "feasible": True,
                "methods": {m: {"outcomes": [o[c]]} for m, o in outcomes.items()},
            }
            for c in range(n)
        ],
    }


def _write(tmp_path: Path, name: str, result: dict) -> Path:
    path = tmp_path / name
    path.write_text(json.dumps(result))
    return path


def _run(*args) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, SCRIPT, *map(str, args)], capture_output=True, text=True)


def test_pools_views_per_configuration(tmp_path):
    # 10 configurations; 'a' succeeds on both views of configurations 0-7, 'b' on one view
    # of 0-3 and both of 4-7: 'a' is ahead in 4 configurations, never behind.
    a = [1] * 8 + [0, 0]
    b0, b1 = [1] * 8 + [0, 0], [0] * 4 + [1] * 4 + [0, 0]
    files = [
        # seed 0 in two files (one per method), merged as `benchmark` does
        _write(tmp_path, "a0.json", _result(0, {"a": a}, top_k=5)),
        _write(tmp_path, "b0.json", _result(0, {"b": b0}, top_k=5)),
        _write(tmp_path, "s1.json", _result(1, {"a": a, "b": b1})),
    ]
    run = _run("--reference", "a", "--msr", *files)
    assert run.returncode == 0, run.stderr
    out = run.stdout
    assert "10 configurations, 2 views each (MSR seeds [0, 1])" in out
    assert re.search(r"\| a \| 80\.0 % \| 80\.0 % \| 80\.0 % \|", out), out
    assert re.search(r"\| b \| 80\.0 % \| 40\.0 % \| 60\.0 % \|", out), out
    assert "| b | 0 / 0, 1 | 4 / 0, 0.12 |" in out  # McNemar per seed
    assert "| b | 4 | 0 | 0.12 |" in out  # pooled sign test: 2 * 0.5**4
    assert "| b | +20.0 points |" in out
    assert "| cabinet/door | 10 | 80.0 % | 60.0 % |" in out  # per target, over all views


def test_bad_input_is_one_line_and_exit_2(tmp_path):
    a = _write(tmp_path, "a.json", _result(0, {"a": [1, 0]}))
    other = _write(tmp_path, "o.json", _result(1, {"a": [1, 0, 1]}))
    run = _run("--reference", "a", "--msr", a, other)
    assert run.returncode == 2 and run.stderr.count("\n") == 1
    assert "MSR seed 1 covers other configurations than seed 0" in run.stderr
    run = _run("--reference", "zz", "--msr", a)
    assert run.returncode == 2 and "--reference 'zz'" in run.stderr
    run = _run("--reference", "a", "--msr", tmp_path / "missing.json")
    assert run.returncode == 2 and "missing.json" in run.stderr


def test_name_equals_file_renames_its_one_method(tmp_path):
    # two trainings of one model, both called 'a' in their files: compared as 'a' and 'a2'
    first = _write(tmp_path, "a.json", _result(0, {"a": [1, 1, 0]}))
    second = _write(tmp_path, "a2.json", _result(0, {"a": [0, 1, 0]}))
    run = _run("--reference", "a", "--msr", first, second)
    assert run.returncode == 2 and "repeats methods ['a']" in run.stderr
    run = _run("--reference", "a", "--msr", first, f"a2={second}")
    assert run.returncode == 0, run.stderr
    assert re.search(r"\| a2 \| 33\.3 % \| 33\.3 % \|", run.stdout), run.stdout
    both = _write(tmp_path, "ab.json", _result(1, {"a": [1, 0, 0], "b": [0, 0, 1]}))
    run = _run("--reference", "a", "--msr", f"c={both}")
    assert run.returncode == 2 and "needs a result of one method, found ['a', 'b']" in run.stderr


def test_pool_compares_methods_over_all_their_views(tmp_path):
    # 'a1', 'a2' (two trainings of a) and 'b1', 'b2', two views each: a succeeds on all four
    # views of configurations 0-2, b on three of them in 0-1 and on all four in 2.
    four = {"a1": [1, 1, 1, 0], "a2": [1, 1, 1, 0], "b1": [1, 1, 1, 0]}
    files = [
        _write(tmp_path, "s0.json", _result(0, {**four, "b2": [0, 0, 1, 0]})),
        _write(tmp_path, "s1.json", _result(1, {**four, "b2": [1, 1, 1, 0]})),
    ]
    run = _run("--reference", "a1", "--msr", *files, "--pool", "a=a1,a2", "b=b1,b2")
    assert run.returncode == 0, run.stderr
    assert "| a | a1, a2 | 4 | 75.0 % |" in run.stdout
    assert "| b | b1, b2 | 4 | 62.5 % |" in run.stdout
    assert "| b | 2 | 0 | 0.5 |" in run.stdout  # sign test over configurations 0 and 1
    assert "| b | +12.5 points |" in run.stdout
    run = _run("--reference", "a1", "--msr", *files, "--pool", "a=a1,zz")
    assert run.returncode == 2 and run.stderr.count("\n") == 1 and "'a=a1,zz'" in run.stderr
    assert run.stdout == ""  # refused before anything is printed
