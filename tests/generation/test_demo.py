"""demo: the whole pipeline on one kitchen writes a report and a result; bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest

from momakitchen.cli.main import main
from momakitchen.frames import base_to_world_xy
from momakitchen.sim.config import STAGE_NAMES


def test_demo_writes_report_and_result(tiny_run, tmp_path, capsys):
    out = tmp_path / "demo"
    assert (
        main(
            [
                "demo",
                "--out",
                str(out),
                "--checkpoint",
                str(tiny_run),
                "--robot",
                "xarm6",
                "--scene-id",
                "5",
            ]
        )
        == 0
    )
    result = json.loads((out / "result.json").read_text())
    assert result["robot"] == "xarm6" and result["scene_id"] == 5
    assert result["trial"]["stage"] in STAGE_NAMES
    assert result["trial"]["success"] == (result["trial"]["stage"] == "success")
    # the trial ran where the chosen pose (viewpoint base frame) lies in the world
    world_xy = base_to_world_xy(
        np.array([result["chosen_pose_base_frame"][:2]]), result["viewpoint_base_pose_world"]
    )[0]
    np.testing.assert_allclose(world_xy, result["chosen_position_world"], atol=2e-4)
    steps = result["seconds"]
    assert sum(v for k, v in steps.items() if k != "total") == pytest.approx(
        steps["total"], abs=0.05
    )
    assert result["grid"]["trials"] > 0 and 0 <= result["ground_truth_at_pose"] <= 1
    assert (out / "report.png").stat().st_size > 50_000
    stdout = capsys.readouterr().out
    assert "[6/6] write the report" in stdout and "report.png" in stdout


def test_demo_bad_input(tmp_path, capsys):
    assert main(["demo", "--out", str(tmp_path / "a"), "--robot", "r2d2"]) == 2
    assert (
        main(["demo", "--out", str(tmp_path / "b"), "--checkpoint", str(tmp_path / "missing")]) == 2
    )
    assert main(["demo", "--out", str(tmp_path / "c"), "--config", "99"]) == 2
    err = capsys.readouterr().err
    assert "unknown robot 'r2d2'" in err and "does not exist" in err
    assert "configuration index must be in [0, " in err
