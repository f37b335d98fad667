"""Does a model serve a robot: the gap to the oracle, its interval, the verdict, and the
`robot-check` command end to end (labelling, closed loop, fine-tuning, resuming)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from momakitchen.cli.main import main
from momakitchen.errors import MomaError
from momakitchen.eval.robot_check import (
    DOES_NOT_SERVE,
    SERVES,
    UNDECIDED,
    check_summary,
    format_check,
    gap_closed_interval,
    gap_interval,
    verdict,
)


def test_gap_interval_is_paired_and_seeded():
    oracle = [1] * 40
    model = [1] * 36 + [0] * 4
    gap, lo, hi = gap_interval(model, oracle)
    assert gap == pytest.approx(0.1)
    assert 0.0 <= lo < gap < hi <= 0.25
    assert gap_interval(model, oracle) == (gap, lo, hi)  # seeded
    # Paired: a model that fails where the oracle fails too has no gap there.
    assert gap_interval([0, 1, 1], [0, 1, 1]) == (0.0, 0.0, 0.0)
    with pytest.raises(MomaError, match="paired outcomes"):
        gap_interval([1], [1, 0])


def test_gap_closed_interval_is_paired_and_seeded():
    oracle = [1] * 30 + [0] * 10
    random = [1] * 4 + [0] * 36
    model = [1] * 27 + [0] * 13  # closes (27 - 4) / (30 - 4) of the gap
    lo, hi = gap_closed_interval(model, oracle, random)
    assert 0.6 < lo < 23 / 26 < hi <= 1.0
    assert gap_closed_interval(model, oracle, random) == (lo, hi)  # seeded
    # Paired: where the model fails exactly where the oracle does, no resample differs.
    assert gap_closed_interval(oracle, oracle, random) == (1.0, 1.0)
    # The oracle no better than random: the share is undefined.
    assert all(np.isnan(gap_closed_interval([1, 0], [0, 0], [0, 0])))
    with pytest.raises(MomaError, match="paired outcomes"):
        gap_closed_interval([1], [1, 0], [0, 0])


def test_verdict_needs_the_whole_interval():
    assert verdict(0.03, 0.0, 0.08, 0.10) == SERVES
    assert verdict(0.08, 0.02, 0.15, 0.10) == UNDECIDED
    assert verdict(0.30, 0.18, 0.42, 0.10) == DOES_NOT_SERVE


def _msr(model, oracle, random):
    records = [
        {
            "feasible": bool(o),
            "methods": {
                "navaff": {"outcomes": [m]},
                "oracle": {"outcomes": [o]},
                "random": {"outcomes": [r]},
            },
        }
        for m, o, r in zip(model, oracle, random, strict=True)
    ]
    return {"methods": {"navaff": {}, "oracle": {}, "random": {}}, "records": records}


def test_check_summary_and_its_words():
    result = _msr([1, 1, 0, 0], [1, 1, 1, 0], [0, 0, 0, 0])
    s = check_summary(result, "navaff", "myarm", 0.10)
    assert s["top1"] == {"navaff": 0.5, "oracle": 0.75, "random": 0.0}
    assert s["gap"] == pytest.approx(0.25) and s["feasible"] == 3
    assert s["gap_closed"] == pytest.approx(0.5 / 0.75)
    text = format_check(s)
    assert "gap to the oracle 25.0 points" in text and text.splitlines()[-1].startswith("verdict")
    with pytest.raises(MomaError, match="oracle solves none of the 2"):
        check_summary(_msr([0, 0], [0, 0], [0, 0]), "navaff", "myarm", 0.10)


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    cfg = tmp_path_factory.mktemp("rc") / "gen.yaml"
    cfg.write_text("scene:\n  configs_per_scene: 2\nviews:\n  episodes: 1\n")
    return cfg


def test_robot_check_labels_judges_and_resumes(small, tmp_path, capsys):
    out = tmp_path / "check"
    argv = ["robot-check", "panda", "--out", str(out), "--scenes", "1", "--config", str(small)]
    assert main([*argv, "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "verdict: " in text
    report = json.loads((out / "report.json").read_text())["before"]
    assert report["robot"] == "panda" and report["configurations"] == 2
    assert report["model"] == "bundled"
    assert set(report["top1"]) == {"bundled", "oracle", "random", "ring", "reachability"}
    assert "classical: ring" in text
    check = json.loads((out / "check.json").read_text())
    assert {r["robot"] for r in check["records"]} == {"panda"}  # labelled for it alone
    # Run again: the closed loop is not run again (its result is reused as it is).
    stamp = (out / "check.json").stat().st_mtime_ns
    assert main([*argv, "--quiet"]) == 0
    assert (out / "check.json").stat().st_mtime_ns == stamp
    assert "closed loop on" not in capsys.readouterr().out


@pytest.mark.slow
def test_robot_check_finetunes_and_reports_again(small, tmp_path, capsys):
    steps = tmp_path / "train.yaml"
    steps.write_text("max_steps: 2\nbatch_size: 2\n")
    out = tmp_path / "check"
    argv = ["robot-check", "panda", "--out", str(out), "--scenes", "1", "--config", str(small)]
    argv += ["--finetune-scenes", "2", "--train-config", str(steps), "--quiet"]
    assert main(argv) == 0
    report = json.loads((out / "report.json").read_text())
    assert (out / "finetuned" / "model.safetensors").is_file()
    assert json.loads((out / "finetune.json").read_text())["max_steps"] == 2
    assert report["after"]["configurations"] == report["before"]["configurations"]
    assert set(report["mcnemar"]) == {"only_finetuned", "only_before", "p"}
    assert "fine-tuned against before" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["nobody"], "unknown robot 'nobody'"),
        (["panda", "--checkpoint", "NORUN"], "--checkpoint 'NORUN' is not a run directory"),
        (
            ["panda", "--finetune-scenes", "2", "--finetune-first-scene-id", "900003"],
            "must not be one of the check's scenes",
        ),
        (["panda", "--tolerance", "-1"], "expected a finite number >= 0, got '-1'"),
    ],
)
def test_bad_input_is_one_line_and_writes_nothing(extra, message, tmp_path, capsys):
    out = tmp_path / "check"
    assert main(["robot-check", *extra, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and "\n" not in err
    assert not out.exists()
