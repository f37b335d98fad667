"""analyses/picks_only_maps.py: the picks-only model's map metrics, composed per category."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from momakitchen.data import EpisodeDataset
from momakitchen.data.manifest import target_opens
from momakitchen.eval.evaluate import evaluate_predictions
from momakitchen.eval.predictions import dataset_episodes, write_predictions
from momakitchen.metrics import METRIC_NAMES

SCRIPT = Path(__file__).resolve().parents[1] / "picks_only_maps.py"


def _script(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, str(SCRIPT), *args], capture_output=True, text=True, check=False
    )


def test_the_composition_equals_evaluating_the_mixed_maps(small_dataset, tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(SCRIPT.parent))
    from picks_only_maps import compose, opened_categories

    data = EpisodeDataset(small_dataset, "all")
    shards = data.manifest["shards"]
    opens = [target_opens(shards[str(sid)]["targets"][c]) for _, sid, c, _, _ in data.index]
    assert any(opens) and not all(opens)  # the premise: both kinds of target
    rng = np.random.default_rng(0)
    episodes = dataset_episodes(data)
    w = {k: rng.uniform(0, 1, n) for k, n in episodes}
    u = {k: rng.uniform(0, 1, n) for k, n in episodes}
    mixed = {k: u[k] if o else w[k] for (k, _), o in zip(episodes, opens, strict=True)}
    reports = {}
    for name, maps in (("w", w), ("u", u), ("mixed", mixed)):
        write_predictions(tmp_path / f"{name}.npz", maps)
        reports[name] = evaluate_predictions(tmp_path / f"{name}.npz", data)
    got = compose(
        reports["w"]["per_category"],
        reports["u"]["per_category"],
        opened_categories(small_dataset),
    )
    assert got["openings"] == sum(opens) and got["episodes"] == len(opens)
    for k in METRIC_NAMES:
        assert got[k] == pytest.approx(reports["mixed"]["metrics"][k], rel=1e-9), k
    # and the two runs differ there, so the test could fail
    assert reports["w"]["metrics"]["pcc"] != reports["mixed"]["metrics"]["pcc"]

    for name, report in reports.items():
        (tmp_path / f"{name}.json").write_text(json.dumps(report))
    out = _script(
        "--data",
        str(small_dataset),
        str(tmp_path / "w.json"),
        str(tmp_path / "u.json"),
        "--check",
        str(tmp_path / "mixed.json"),
    )
    assert out.returncode == 0, out.stderr
    composed, measured = out.stdout.splitlines()[-2:]
    assert composed.split("|")[1:] == measured.split("|")[1:]


def test_bad_input_is_one_line_and_exit_2(small_dataset, tmp_path):
    one = {"episodes": 3, "per_category": {"fruit": {"episodes": 3.0}}}
    other = {"episodes": 4, "per_category": {"fruit": {"episodes": 4.0}}}
    (tmp_path / "one.json").write_text(json.dumps(one))
    (tmp_path / "other.json").write_text(json.dumps(other))
    (tmp_path / "bare.json").write_text(json.dumps({"episodes": 3}))
    d = str(small_dataset)
    cases = {
        (str(tmp_path / "one.json"), str(tmp_path / "other.json")): "hold 3 and 4 episodes",
        (str(tmp_path / "one.json"), str(tmp_path / "bare.json")): "with per_category",
    }
    for (first, second), message in cases.items():
        out = _script("--data", d, first, second)
        assert out.returncode == 2, (message, out.stderr)
        assert message in out.stderr and len(out.stderr.strip().splitlines()) == 1, out.stderr
    out = _script("--data", str(tmp_path), str(tmp_path / "one.json"), str(tmp_path / "one.json"))
    assert out.returncode == 2 and "not a momakitchen dataset" in out.stderr
