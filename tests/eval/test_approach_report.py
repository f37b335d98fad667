"""The approach track's tables: rows, McNemar pairs, the stop-error sweep, merging runs."""

from __future__ import annotations

import pytest

from momakitchen.errors import MomaError
from momakitchen.eval.approach.report import (
    halving_error,
    markdown_table,
    merge_results,
    pairwise,
    report_markdown,
    summarize,
)


def _record(method, policy, config, success, sweep=None):
    rec = {
        "scene_id": 1,
        "config_index": config,
        "robot": "panda" if config % 2 else "ur5e",
        "category": "bottle",
        "feasible": True,
        "start": "far",
        "start_distance": 4.0 + config / 10,
        "method": method,
        "policy": policy,
        "success": success,
        "spl": 0.8 * success,
        "n_looks": 1 if policy != "-" else 0,
        "seconds": {
            "driving": 8.0,
            "turning": 1.0,
            "looking": 1.0,
            "inference": 0.2,
            "total": 10.2,
        },
        "cpu_seconds": 1.5,
        "stage": "success" if success else "ik_failed",
        "blocked": False,
    }
    if sweep is not None:
        rec["stop_sweep"] = sweep
    return rec


def _result(records, methods, sweep=()):
    return {
        "dataset": "d",
        "configurations": 10,
        "config": {
            "split": "test",
            "seed": 0,
            "perception": "realistic",
            "stop_sweep": sweep,
            "starts": ["far"],
            "policies": ["single"],
        },
        "methods": methods,
        "records": records,
        "skipped": [],
    }


def test_rows_pairs_and_sweep():
    sweep = [[0, 0], [3, 2], [6, 4], [10, 6]]
    a = [
        _record("navaff", "single", c, int(c < 8), [1, 1, int(c < 6), int(c < 3)])
        for c in range(10)
    ]
    b = [_record("oracle", "-", c, int(c < 2), [1, 1, 1, 1]) for c in range(10)]
    result = _result(a + b, ["navaff", "oracle"], sweep)
    rows = {r["method"]: r for r in summarize(result)}
    nav = rows["navaff"]
    assert nav["success"] == pytest.approx(0.8) and nav["spl"] == pytest.approx(0.64)
    assert nav["failures"] == {"ik_failed": 2} and nav["episodes"] == 10
    assert nav["per_robot"]["panda"] == {"success": 0.8, "episodes": 5}
    assert nav["stop_sweep"]["success"] == [1.0, 1.0, 0.6, 0.3]
    # Half of 1.0 is reached between 6 cm (0.6) and 10 cm (0.3): 6 + 4 * 0.1 / 0.3.
    assert nav["stop_sweep"]["halving_cm"] == pytest.approx(6 + 4 / 3)
    assert rows["oracle"]["stop_sweep"]["halving_cm"] is None
    # An episode without a trial fails at every stop error: the sweep's rates are over
    # every episode, as success is.
    a[0].pop("stop_sweep")
    assert summarize(result)[0]["stop_sweep"]["success"] == [0.9, 0.9, 0.5, 0.2]
    (pair,) = pairwise(result)
    assert (pair["only_a"], pair["only_b"]) == (6, 0)  # navaff solves 6 the oracle does not
    assert pair["p"] == pytest.approx(2 / 64)
    # Ten configurations cannot find even the largest lead with 80 % power.
    assert pair["detectable_lead"] is None
    text = report_markdown(result)
    assert "| far (4.5 m) | navaff (single) | 10 | 80.0 % | 0.640 |" in markdown_table(
        summarize(result)
    )
    assert "McNemar" in text and "halves at" in text
    # The header names what the robot knew of the room where the run recorded it.
    assert "map" not in text.splitlines()[2]
    result["config"]["map"] = "static"
    assert "map `static` (a costmap cell marked at 1 depth point);" in report_markdown(result)
    result["config"]["obstacle_min_points"] = 10
    assert "marked at 10 depth points);" in report_markdown(result)
    result["config"]["map"] = "full"
    assert "map `full`;" in report_markdown(result)


def test_halving_error():
    assert halving_error([0, 3, 6], [0.8, 0.4, 0.1]) == pytest.approx(3.0)
    assert halving_error([0, 3, 6], [0.8, 0.7, 0.6]) is None
    assert halving_error([0, 3], [0.0, 0.0]) is None


def test_merge_results_checks_the_parts_fit():
    a = _result([_record("navaff", "single", c, 1) for c in range(3)], ["navaff"])
    b = _result([_record("oracle", "-", c, 0) for c in range(3)], ["oracle"])
    merged = merge_results([("a", a), ("b", b)])
    assert merged["methods"] == ["navaff", "oracle"] and len(merged["records"]) == 6
    assert {r["method"] for r in merged["results"]} == {"navaff", "oracle"}
    with pytest.raises(MomaError, match="repeats methods"):
        merge_results([("a", a), ("a2", a)])
    other = {**b, "config": {**b["config"], "seed": 1}}
    with pytest.raises(MomaError, match="other settings"):
        merge_results([("a", a), ("b", other)])


def test_merge_results_joins_the_parts_of_a_split():
    def run(method, k, configs):
        recs = [_record(method, "single", c, c % 2) for c in configs]
        out = _result(recs, [method])
        out["config"] = {**out["config"], "part": [k, 2]}
        out["configurations"] = len(configs)
        return out

    parts = [
        ("n1", run("navaff", 1, [0, 2])),
        ("n2", run("navaff", 2, [1, 3, 5])),
        ("o1", run("oracle", 1, [0, 2])),
        ("o2", run("oracle", 2, [1, 3, 5])),
    ]
    merged = merge_results(parts)
    assert merged["configurations"] == 5 and merged["config"]["part"] == [1, 1]
    assert {r["method"]: r["episodes"] for r in merged["results"]} == {"navaff": 5, "oracle": 5}
    with pytest.raises(MomaError, match="whole split: got 1/2"):
        merge_results(parts[:1] + parts[2:3])
    with pytest.raises(MomaError, match="part 2/2 has methods"):
        merge_results(parts[:3])
