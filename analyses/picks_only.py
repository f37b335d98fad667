"""What the dexterity weight for picks only (``ModelConfig.index_picks_only``) scores on
configurations already run with the weight on every target and without it.

    python analyses/picks_only.py \
        results/body/dexterity/t300-msr-r05.json.gz:navaff \
        results/body/retrained/t300-msr.json.gz:navaff

The weight is a gate on each episode's prediction, with no weights of its own: where the
robot picks its target, a picks-only model predicts what the weighted model does, and where
it opens it, what the unweighted model does. So on the same configurations (same data,
seed and settings, the same machine) its records are the weighted run's for the picks and
the unweighted run's for the openings, record for record. Each argument is a ``momakitchen
msr --json`` or ``approach --json`` file with ``:METHOD``, the model's method in it. Prints,
per policy (``msr``: Top-1), the configurations both runs hold, how many of them open
their target, and each model's successes; with ``--baselines FILE`` (a run holding the
oracle and random on the same configurations), the share of the random -> oracle gap each
closes and ``robot-check``'s verdict on the picks-only model (its paired bootstrap, 10
points' tolerance). ``--json FILE`` (``approach`` results) writes the picks-only model's
records, which ``drive_pooled.py`` pools with runs of it on other kitchens.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from analysis_cli import run_main

from momakitchen.data.manifest import target_opens
from momakitchen.errors import MomaError
from momakitchen.eval.robot_check import gap_interval, verdict
from momakitchen.fileio import atomic_write_text, read_json_object

BASELINES = ("oracle", "random")
TOLERANCE = 0.1  # robot-check's default: within 10 points of the oracle serves
Key = tuple[str, int, int, str]  # policy, scene, configuration, start


def _key(r: dict[str, Any]) -> Key:
    """An ``approach`` record's (policy, scene, configuration, start)."""
    return (str(r["policy"]), int(r["scene_id"]), int(r["config_index"]), str(r.get("start", "")))


def _choose(weighted: dict[Key, Any], unweighted: dict[Key, Any], opens: Any) -> dict[Key, Any]:
    """The picks-only model's entries on the keys both runs hold: the weighted run's where
    the robot picks its target, the unweighted run's where ``opens(entry)`` says it opens."""
    both = sorted(weighted.keys() & unweighted.keys())
    return {k: unweighted[k] if opens(weighted[k]) else weighted[k] for k in both}


def outcomes(
    path: str, methods: tuple[str, ...], result: dict[str, Any] | None = None
) -> dict[str, dict[Key, tuple[bool, int]]]:
    """Per method of ``methods``: ``{(policy, scene, config, start): (opens, success)}`` of
    an ``msr`` (policy ``top1``) or ``approach`` result (``result``: ``path`` already read)."""
    result = read_json_object(path) if result is None else result
    records = result.get("records")
    if not isinstance(records, list):
        raise MomaError(f"{path!r} is not a momakitchen msr or approach --json result")
    out: dict[str, dict[Key, tuple[bool, int]]] = {m: {} for m in methods}
    for r in records:
        opens = target_opens(str(r["target"]))
        ident = (int(r["scene_id"]), int(r["config_index"]))
        if "methods" in r:  # msr: every method in one record
            for m in methods:
                v = r["methods"].get(m)
                if v is not None:
                    out[m][("top1", *ident, "")] = (
                        opens,
                        int(v["outcomes"][0]) if v["outcomes"] else 0,
                    )
        elif r.get("method") in methods:
            out[r["method"]][_key(r)] = (opens, int(r["success"]))
    for m, rows in out.items():
        if not rows:
            raise MomaError(f"{path!r} has no record of method {m!r}")
    return out


def compose(
    weighted: dict[Key, tuple[bool, int]], unweighted: dict[Key, tuple[bool, int]]
) -> dict[Key, tuple[bool, int]]:
    """The picks-only model's outcomes on the configurations both runs hold."""
    both = sorted(weighted.keys() & unweighted.keys())
    if not both:
        raise MomaError("the two runs share no configuration")
    for k in both:
        if weighted[k][0] != unweighted[k][0]:
            raise MomaError(f"configuration {k[1:3]} has another target in the two runs")
    return _choose(weighted, unweighted, lambda v: v[0])


def table(
    weighted: dict[Key, tuple[bool, int]],
    unweighted: dict[Key, tuple[bool, int]],
    baselines: dict[str, dict[Key, tuple[bool, int]]] | None = None,
) -> list[dict[str, Any]]:
    """One row per policy: configurations, openings, and successes of the weighted, the
    unweighted and the picks-only model (and the gap each closes, with baselines)."""
    picks = compose(weighted, unweighted)
    rows = []
    for policy in sorted({k[0] for k in picks}):
        keys = [k for k in picks if k[0] == policy]
        row: dict[str, Any] = {
            "policy": policy,
            "configurations": len(keys),
            "openings": sum(picks[k][0] for k in keys),
        }
        for name, rows_of in (
            ("weighted", weighted),
            ("unweighted", unweighted),
            ("picks_only", picks),
        ):
            row[name] = sum(rows_of[k][1] for k in keys)
        if baselines:
            base = {
                b: {(k[1], k[2], k[3]): v[1] for k, v in rows_b.items()}
                for b, rows_b in baselines.items()
            }
            at = [(k[1], k[2], k[3]) for k in keys]
            missing = [a for a in at if any(a not in base[b] for b in BASELINES)]
            if missing:
                raise MomaError(f"the baselines lack configuration {missing[0][:2]}")
            oracle, rand = ([base[b][a] for a in at] for b in BASELINES)
            row |= {"oracle": sum(oracle), "random": sum(rand)}
            span = sum(oracle) - sum(rand)
            for name in ("weighted", "unweighted", "picks_only"):
                row[f"{name}_gap"] = (row[name] - sum(rand)) / span if span else None
            # robot-check's estimator and verdict, on the picks-only model's outcomes
            gap, low, high = gap_interval([picks[k][1] for k in keys], oracle)
            row["check"] = {
                "gap": gap,
                "interval": [low, high],
                "verdict": verdict(gap, low, high, TOLERANCE),
            }
        rows.append(row)
    return rows


Run = tuple[str, str, dict[str, Any]]  # a FILE:METHOD argument: the file, the method, its result


def composed_run(weighted: Run, unweighted: Run) -> dict[str, Any]:
    """The picks-only model's ``approach`` result on the configurations both runs
    (:func:`_load`) hold: the weighted run's records where the robot picks its target,
    the unweighted run's where it opens it, as method ``picks_only``, with the weighted
    run's settings (so ``drive_pooled.py`` pools it with measured runs)."""
    rows = []
    for path, method, result in (weighted, unweighted):
        mine = {
            _key(r): r
            for r in result.get("records", [])
            if r.get("method") == method and "methods" not in r
        }
        if not mine:
            raise MomaError(f"{path!r} holds no approach record of method {method!r}")
        rows.append(mine)
    chosen = _choose(*rows, lambda r: target_opens(str(r["target"])))
    records = [{**r, "method": "picks_only"} for r in chosen.values()]
    return {
        "config": weighted[2]["config"],
        "composed_from": [f"{path}:{method}" for path, method, _ in (weighted, unweighted)],
        "records": records,
    }


def _load(arg: str) -> Run:
    path, _, method = arg.partition(":")
    if not method:
        raise MomaError(f"give the model's method as FILE:METHOD, got {arg!r}")
    return path, method, read_json_object(path)


def _read(run: Run) -> dict[Key, tuple[bool, int]]:
    path, method, result = run
    return outcomes(path, (method,), result)[method]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("weighted", help="FILE:METHOD, run with the weight on every target")
    ap.add_argument("unweighted", help="FILE:METHOD, the same model without the weight")
    ap.add_argument("--baselines", help="FILE holding the oracle and random")
    ap.add_argument(
        "--json", type=Path, help="approach results: write the picks-only model's records here"
    )
    args = ap.parse_args()
    weighted, unweighted = _load(args.weighted), _load(args.unweighted)
    if args.json:
        composed = composed_run(weighted, unweighted)
        atomic_write_text(args.json, json.dumps(composed) + "\n")
    w, u = _read(weighted), _read(unweighted)
    base = outcomes(args.baselines, BASELINES) if args.baselines else None
    for row in table(w, u, base):
        n = row["configurations"]
        line = f"{row['policy']}: {n} configurations ({row['openings']} open their target)"
        for name in ("weighted", "unweighted", "picks_only"):
            gap = row.get(f"{name}_gap")
            line += f"; {name} {100 * row[name] / n:.1f} %"
            line += f" ({gap:.2f} of the gap)" if gap is not None else ""
        if base:
            c = row["check"]
            low, high = (100 * v for v in c["interval"])
            line += (
                f"; oracle {100 * row['oracle'] / n:.1f} %, random {100 * row['random'] / n:.1f} %"
                f"; picks only, robot-check: {100 * c['gap']:.1f} points below the oracle "
                f"[{low:.1f}, {high:.1f}], {c['verdict']}"
            )
        print(line)


if __name__ == "__main__":
    run_main(main, "picks_only.py")
