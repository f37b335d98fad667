"""demo: the whole pipeline on one kitchen writes a report and a result; bad input."""

from __future__ import annotations

import json

from momakitchen.cli.main import main
from momakitchen.sim.trials import Stage


def test_demo_writes_report_and_result(tiny_run, tmp_path, capsys):
    out = tmp_path / "demo"
    assert main(["demo", "--out", str(out), "--checkpoint", str(tiny_run), "--robot",
                 "xarm6", "--scene-id", "5"]) == 0
    result = json.loads((out / "result.json").read_text())
    assert result["robot"] == "xarm6" and result["scene_id"] == 5
    assert Stage[result["trial"]["stage"].upper()] is not None
    assert result["trial"]["success"] == (result["trial"]["stage"] == "success")
    assert result["grid"]["trials"] > 0 and 0 <= result["ground_truth_at_pose"] <= 1
    assert (out / "report.png").stat().st_size > 50_000
    stdout = capsys.readouterr().out
    assert "[6/6] write the report" in stdout and "report.png" in stdout


def test_demo_bad_input(tmp_path, capsys):
    assert main(["demo", "--out", str(tmp_path / "a"), "--robot", "r2d2"]) == 2
    assert main(["demo", "--out", str(tmp_path / "b"), "--checkpoint",
                 str(tmp_path / "missing")]) == 2
    assert main(["demo", "--out", str(tmp_path / "c"), "--config", "99"]) == 2
    err = capsys.readouterr().err
    assert "unknown robot 'r2d2'" in err and "does not exist" in err
    assert "configuration index" in err or "bundled checkpoint" in err
