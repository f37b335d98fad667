"""analyses/reach_band.py: each pick placed against the successful trials and the arm's map."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from momakitchen.data.manifest import load_manifest
from momakitchen.data.shard import SceneShard

SCRIPT = Path(__file__).resolve().parents[1] / "reach_band.py"


def _result(data: Path) -> tuple[dict, int]:
    """Method "m" picks, in each feasible configuration, its farthest successful labelling
    trial (outcome success) and, as method "far", a point 0.5 m farther out on the line from
    the anchor (outcome out_of_reach); the result and how many configurations were used."""
    (sid, entry), *_ = load_manifest(data)["shards"].items()
    records = []
    with SceneShard(data / entry["file"]) as shard:
        for ci in shard.config_indices():
            labels = shard.configuration(ci)
            ok = labels.trial_positions[labels.trial_stages == 0]
            if not len(ok):
                continue
            anchor = np.asarray(labels.anchor[:2])
            far = ok[np.argmax(np.hypot(*(ok - anchor).T))]
            out = far + 0.5 * (far - anchor) / np.hypot(*(far - anchor))
            methods = {
                "m": {"points": [far.tolist()], "outcomes": [1], "stages": [0]},
                "far": {"points": [out.tolist()], "outcomes": [0], "stages": [2]},
                "random": {"points": [out.tolist()], "outcomes": [0], "stages": [2]},
            }
            records.append(
                {"scene_id": int(sid), "config_index": ci, "feasible": True, "methods": methods}
            )
    return {"records": records}, len(records)


def test_a_pick_beyond_every_success_reads_beyond_and_out_of_reach(real_dataset, monkeypatch):
    monkeypatch.syspath_prepend(str(SCRIPT.parent))
    from reach_band import band_rows, format_band

    result, n = _result(real_dataset)
    if not n:
        pytest.skip("the test scene has no feasible configuration")
    picks, trials = band_rows(real_dataset, result, None)
    assert set(picks) == {"m", "far"}  # random's picks are no map's
    (success,) = picks["m"].values()
    assert len(success) == n and all(abs(beyond) < 1e-6 for _, beyond, _ in success)
    (beyond,) = picks["far"].values()
    assert all(abs(b - 0.5) < 1e-6 for _, b, _ in beyond)
    assert all(d < 0 for _, _, d in beyond)  # half a metre past every success: out of reach
    assert sum(len(v) for v in trials.values()) > 0 and "success" in trials
    table = format_band(picks, trials)
    assert "far | out_of_reach" in table and "m | success" in table


def test_a_scene_missing_from_the_data_is_one_line(real_dataset, tmp_path):
    bad = {"records": [{"scene_id": 99, "config_index": 0, "feasible": True, "methods": {}}]}
    path = tmp_path / "msr.json"
    path.write_text(json.dumps(bad))
    cmd = [sys.executable, str(SCRIPT), "--data", str(real_dataset), "--msr", str(path)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stderr.strip() == (
        f"reach_band.py: error: --msr scene 99 is not in --data {str(real_dataset)!r}"
    )
