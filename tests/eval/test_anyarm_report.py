"""scripts/anyarm_report.py: the held-out robot tables from msr and evaluate results."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

SCRIPTS = Path(__file__).resolve().parents[2] / "scripts"
MODELS = ["navaff", "pointnet2", "navaff:navaff-anyarm", "pointnet2:pointnet2-anyarm"]


def _robot_set(root: Path, name: str, outcomes: dict[str, list[int]], pcc: dict[str, float]):
    """A folder with an msr.json (Top-1 outcome per configuration of every method) and one
    MODEL-maps.json per model."""
    folder = root / name
    folder.mkdir()
    n = len(outcomes["oracle"])
    records = [
        {"methods": {m: {"outcomes": [won[c]]} for m, won in outcomes.items()}} for c in range(n)
    ]
    methods = {m: {"per_robot": {name: {}}} for m in outcomes}
    (folder / "msr.json").write_text(json.dumps({"methods": methods, "records": records}))
    for m in MODELS:
        (folder / f"{m.split(':')[-1]}-maps.json").write_text(
            json.dumps({"metrics": {"pcc": pcc[m], "sim": 0.5}})
        )


def _report(root: Path) -> subprocess.CompletedProcess:
    cmd = [sys.executable, str(SCRIPTS / "anyarm_report.py"), str(root)]
    return subprocess.run(cmd, capture_output=True, text=True, check=False)


def test_gap_closed_pcc_and_mcnemar(tmp_path):
    oracle, random = [1] * 10, [0] * 10
    trained = {"oracle": oracle, "random": random, **{m: [1] * 10 for m in MODELS}}
    _robot_set(tmp_path, "trained", trained, dict.fromkeys(MODELS, 0.8))
    # Held out: the any-arm NavAff solves 9 of 10, the rest 5; PointNet++ any-arm's maps
    # fall 0.1 below its trained PCC.
    held = {"oracle": oracle, "random": random, "navaff:navaff-anyarm": [1] * 9 + [0]}
    held |= {m: [1] * 5 + [0] * 5 for m in ("navaff", "pointnet2", "pointnet2:pointnet2-anyarm")}
    pcc = dict(zip(MODELS, [0.78, 0.79, 0.77, 0.7], strict=True))
    _robot_set(tmp_path, "gen3", held, pcc)
    out = _report(tmp_path)
    assert out.returncode == 0, out.stderr
    report = json.loads((tmp_path / "report.json").read_text())
    gen3 = report["sets"]["gen3"]["models"]
    assert gen3["navaff:navaff-anyarm"]["gap_closed"] == 0.9
    assert gen3["navaff"]["gap_closed"] == 0.5
    # 9 of 10 against an oracle that solves all and a random that solves none: the
    # interval of the share holds it and reaches 1 (every resample at most 10 of 10).
    lo, hi = gen3["navaff:navaff-anyarm"]["gap_closed_95"]
    assert lo < 0.9 < hi == 1.0
    goals = report["goals"]
    assert goals["navaff:navaff-anyarm"]["gen3"]["gap_closed_met"]
    assert goals["navaff:navaff-anyarm"]["gen3"]["pcc_met"]
    assert not goals["navaff"]["gen3"]["gap_closed_met"]
    assert not goals["pointnet2:pointnet2-anyarm"]["gen3"]["pcc_met"]
    pooled = report["mcnemar"]["navaff:navaff-anyarm vs navaff"]["held-out, pooled"]
    assert (pooled["only_a"], pooled["only_b"]) == (4, 0)
    assert "| trained (trained) | 10 |" in out.stdout
    assert "NavAff, any-arm: met on 1 of 1" in out.stdout


def test_missing_folders_are_one_line(tmp_path):
    out = _report(tmp_path)
    assert out.returncode == 2
    assert out.stderr.count("\n") == 1 and "held-out" in out.stderr


def test_more_msr_files_add_models_and_must_agree(tmp_path):
    oracle, random = [1] * 10, [0] * 10
    base = {"oracle": oracle, "random": random, "navaff": [1] * 5 + [0] * 5}
    for name in ("trained", "gen3"):
        _robot_set(tmp_path, name, base, dict.fromkeys(MODELS, 0.8))
    scaled = "navaff:navaff-anyarm-scaled"
    (tmp_path / "gen3" / "navaff-anyarm-scaled-maps.json").write_text(
        json.dumps({"metrics": {"pcc": 0.76, "sim": 0.5}})
    )

    def extra(folder: str, navaff: list[int], new: list[int]) -> None:
        records = [
            {"methods": {"navaff": {"outcomes": [a]}, scaled: {"outcomes": [b]}}}
            for a, b in zip(navaff, new, strict=True)
        ]
        methods = {m: {"per_robot": {folder: {}}} for m in ("navaff", scaled)}
        path = tmp_path / folder / "msr-scaled.json"
        path.write_text(json.dumps({"methods": methods, "records": records}))

    extra("gen3", base["navaff"], [1] * 9 + [0])
    out = _report(tmp_path)
    assert out.returncode == 0, out.stderr
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["sets"]["gen3"]["models"][scaled]["gap_closed"] == 0.9
    assert scaled not in report["sets"]["trained"]["models"]
    # The bundled model's outcomes in the added file must be those of msr.json.
    extra("gen3", [0] * 10, [1] * 10)
    out = _report(tmp_path)
    assert out.returncode == 2
    assert "navaff's outcomes differ" in out.stderr
