"""The label audit: its trials are MSR's, its re-runs are displaced as documented, its
figures add up, and the command resumes and refuses bad input."""

from __future__ import annotations

import json
import math
from types import SimpleNamespace

import numpy as np
import pytest

from momakitchen.cli.main import main
from momakitchen.errors import MomaError
from momakitchen.eval import audit as au
from momakitchen.sim.config import Stage


class _Recorder:
    """A stand-in runner that records where it was asked to try, succeeding east of x=0."""

    def __init__(self) -> None:
        self.calls: list[tuple[float, float, float | None]] = []

    def run(self, x: float, y: float, yaw: float | None = None):
        self.calls.append((x, y, yaw))
        ok = x > 0
        return SimpleNamespace(success=ok, stage=Stage.SUCCESS if ok else Stage.IK_FAILED)


def test_stability_reruns_are_displaced_as_documented():
    runner = _Recorder()
    config = au.AuditConfig(offsets=(0.03, 0.05), yaw_offset_deg=10.0)
    out = au._stability(runner, np.array([[0.02, 1.0]]), (0.02, 2.0), config)
    xy = [(round(x - 0.02, 4), round(y - 1.0, 4)) for x, y, yaw in runner.calls if yaw is None]
    assert xy == [
        (0.03, 0.0), (-0.03, 0.0), (0.0, 0.03), (0.0, -0.03),
        (0.05, 0.0), (-0.05, 0.0), (0.0, 0.05), (0.0, -0.05),
    ]  # fmt: skip
    yaws = [yaw for *_, yaw in runner.calls if yaw is not None]
    facing = math.pi / 2  # the target is straight ahead in +y
    assert yaws == pytest.approx([facing + math.radians(10), facing - math.radians(10)])
    # x = 0.02 - 0.03 < 0 fails, as does x = 0.02 - 0.05.
    assert out["3cm"]["outcomes"] == [1, 0, 1, 1]
    assert out["5cm"]["outcomes"] == [1, 0, 1, 1]
    assert out["5cm"]["stages"][1] == Stage.IK_FAILED
    assert out["yaw10"]["outcomes"] == [1, 1]


def test_stability_cap_spreads_the_points():
    runner = _Recorder()
    config = au.AuditConfig(offsets=(0.03,), max_stability_points=2)
    pts = np.array([[1.0, 0.0], [2.0, 0.0], [3.0, 0.0]])
    au._stability(runner, pts, (0.0, 5.0), config)
    assert {round(x) for x, _, yaw in runner.calls if yaw is not None} == {1, 3}


def _record(robot, target, feasible, oracle, covering, miss=None, stab=(1, 1)):
    stages = {n: 0 for n in ("success", "base_collision", "out_of_reach", "ik_failed",
                             "arm_collision", "execution_failed")}  # fmt: skip
    stages["success" if feasible else "execution_failed"] = 3
    stages["base_collision"] = 9
    rec = {
        "robot": robot,
        "target": target,
        "feasible": feasible,
        "grid": {"stages": stages},
        "stability": {k: {"outcomes": list(stab), "stages": []} for k in ("3cm", "5cm", "yaw10")},
        "views_covering": covering,
        "methods": {
            "oracle": {"outcomes": oracle},
            "random": {"outcomes": [0, 0]},
            "nearest": {"outcomes": [1, 0]},
        },
    }
    if miss:
        rec["oracle_miss"] = {"reason": miss, "stage": "execution_failed"}
    return rec


def test_summary_figures_add_up():
    records = [
        _record("panda", "bottle", True, [1, 0], [True, True, False], stab=(1, 0)),
        _record("panda", "fridge/door", False, [0, 0], [False], miss="infeasible", stab=()),
        _record("ur5e", "bottle", True, [0, 1], [True], miss="near_success"),
    ]
    s = au.summarize(records, au.AuditConfig())
    o = s["overall"]
    assert o["configurations"] == 3
    assert o["infeasible"] == pytest.approx(1 / 3)
    # Grid base collisions say where the grid is, not why the configuration failed.
    assert o["infeasible_stage"] == "execution_failed"
    assert o["msr"]["oracle"]["top1"] == pytest.approx(1 / 3)
    assert o["msr"]["oracle"]["top1_feasible"] == pytest.approx(1 / 2)
    assert o["msr"]["oracle"]["topk"] == pytest.approx((0.5 + 0 + 0.5) / 3)
    assert o["msr"]["nearest"]["top1"] == 1.0
    assert o["coverage"] == pytest.approx(3 / 4)  # views of feasible configurations only
    assert o["stability"]["3cm"] == pytest.approx(3 / 4)
    assert o["oracle_misses"] == {"infeasible": 1, "near_success": 1}
    assert set(s["per_robot"]) == {"panda", "ur5e"}
    assert s["per_target"]["fridge/door"]["infeasible"] == 1.0
    table = au.format_audit_table(s, au.AuditConfig())
    assert "| **all** | 3 | 33 % | execution_failed |" in table
    assert au.audit_figure(s, au.AuditConfig())[:8] == b"\x89PNG\r\n\x1a\n"


def test_the_dominant_failure_of_infeasible_configurations_is_a_failure():
    """Where the grid's only failures are geometric (the base does not fit, out of
    reach), the table names that stage, never "success" (a stage with zero trials)."""
    record = _record("panda", "bottle", False, [0, 0], [False], miss="infeasible", stab=())
    record["grid"]["stages"]["execution_failed"] = 0
    record["grid"]["stages"]["out_of_reach"] = 4
    s = au.summarize([record], au.AuditConfig())
    assert s["overall"]["infeasible_stage"] == "base_collision"
    assert "success" not in s["overall"]["infeasible_stages"]
    assert "success" not in au.format_audit_table(s, au.AuditConfig())


@pytest.mark.parametrize(
    "kwargs",
    [{"offsets": ()}, {"offsets": (0.0,)}, {"yaw_offset_deg": -1.0}, {"max_stability_points": -1}],
)
def test_bad_config_is_refused(kwargs):
    with pytest.raises(MomaError, match="AuditConfig"):
        au.AuditConfig(**kwargs)


def test_audit_command_on_a_real_scene(real_dataset, tmp_path, monkeypatch, capsys):
    from momakitchen.eval.msr import MsrConfig, run_msr

    out = tmp_path / "audit"
    args = ["audit", "--data", str(real_dataset), "--out", str(out), "--quiet"]
    assert main([*args, "--max-stability-points", "1"]) == 0
    result = json.loads((out / "audit.json").read_text())
    assert result["configurations"] == 2
    assert (out / "audit.png").read_bytes()[:4] == b"\x89PNG"
    assert "| **all** | 2 |" in (out / "audit.md").read_text()
    # The oracle's trials are exactly those of `momakitchen msr --split all`.
    msr = run_msr(real_dataset, methods=["oracle"], config=MsrConfig(split="all"))
    for rec, ref in zip(result["records"], msr["records"], strict=True):
        assert rec["methods"]["oracle"] == ref["methods"]["oracle"]
        n_success = rec["grid"]["successes"]
        assert len(rec["stability"]["3cm"]["outcomes"]) == 4 * min(n_success, 1)
        assert len(rec["views_covering"]) == 2

    # A second run reuses the per-scene records: no trial runs again.
    def no_trials(*a, **k):
        raise AssertionError("the audit ran again")

    monkeypatch.setattr(au, "audit_shard", no_trials)
    capsys.readouterr()
    assert main([*args, "--max-stability-points", "1"]) == 0
    assert json.loads((out / "audit.json").read_text())["records"] == result["records"]


@pytest.mark.parametrize(
    "args, message",
    [
        (["--scenes", "5-3"], "ends before it starts"),
        (["--scenes", "x"], "expected scene ids as A-B or A"),
        (["--data", "/nonexistent/ds"], "/nonexistent/ds"),
    ],
)
def test_audit_bad_input(args, message, tmp_path, capsys):
    assert main(["audit", *args, "--out", str(tmp_path / "o")]) == 2
    assert not (tmp_path / "o").exists()  # nothing created for bad input
    err = capsys.readouterr().err.strip()
    assert message in err and "\n" not in err
