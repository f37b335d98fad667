"""The driven track's success and share of the random -> oracle gap, pooled over runs.

    python analyses/drive_pooled.py \
        results/body/dexterity/panda_public06-drive-r05.json.gz:navaff \
        results/body/gatefp/fresh-977000/panda_public06-drive-gatedfp.json.gz:oracle,random \
        results/body/drive30/panda_public06-drive-977015.json.gz

Each argument is a ``momakitchen approach --json`` file, optionally with ``:METHOD,...``,
the methods to read from it (default: all). The oracle and random rows and one model's
(every other method read; its name may differ from file to file) are paired by
configuration, so kitchens driven in separate runs, and baselines run apart from the
model, pool into one figure. The runs must share their settings (perception, starts,
motion, map, looks, seed). Prints, per policy of the model: episodes, success, the share of
the gap closed with its 95 % paired-bootstrap interval over configurations (the
``robot-check`` estimator), the oracle's and random's success and the model's misses by
cause; then the same for each run of the model alone.
"""

from __future__ import annotations

import argparse
import json
from collections import Counter
from pathlib import Path
from typing import Any

from analysis_cli import run_main

from momakitchen.errors import MomaError
from momakitchen.eval.robot_check import gap_closed_interval
from momakitchen.fileio import atomic_write_text, read_json_object

BASELINES = ("oracle", "random")
# Settings that may differ between runs pooled: which rows and which part they ran.
PER_RUN = ("policies", "part", "max_configs", "split")


def read_run(arg: str) -> tuple[str, dict[str, Any], set[str] | None]:
    """(path, approach result, the methods to read or None for all) of one argument."""
    path, _, methods = arg.partition(":")
    result = read_json_object(path)
    if "records" not in result or "config" not in result:
        raise MomaError(f"{path!r} is not a momakitchen approach --json result")
    return path, result, set(methods.split(",")) if methods else None


def pooled(runs: list[tuple[str, dict[str, Any], set[str] | None]]) -> dict[str, Any]:
    """``{"outcomes": {(role, policy): {(scene, config): (success, stage)}}, "run_of":
    {(scene, config): path of the model's run}}``; role ``model`` or a baseline."""
    settings = None
    outcomes: dict[tuple[str, str], dict[tuple[int, int], tuple[int, str]]] = {}
    run_of: dict[tuple[int, int], str] = {}
    for path, result, wanted in runs:
        config = {k: v for k, v in result["config"].items() if k not in PER_RUN}
        if settings is None:
            settings = (path, config)
        elif config != settings[1]:
            differ = sorted(
                k for k in config.keys() | settings[1].keys() if config.get(k) != settings[1].get(k)
            )
            raise MomaError(
                f"{path!r} was driven with other settings than {settings[0]!r}: {', '.join(differ)}"
            )
        found = {r["method"] for r in result["records"]}
        if wanted and wanted - found:
            raise MomaError(
                f"{path!r} has no method {sorted(wanted - found)[0]!r}: {', '.join(sorted(found))}"
            )
        models = sorted((wanted or found) - set(BASELINES))
        if len(models) > 1:
            raise MomaError(
                f"{path!r} holds several models ({', '.join(models)}); name one as FILE:METHOD"
            )
        for r in result["records"]:
            if wanted and r["method"] not in wanted:
                continue
            role = r["method"] if r["method"] in BASELINES else "model"
            key = (int(r["scene_id"]), int(r["config_index"]))
            rows = outcomes.setdefault((role, r["policy"]), {})
            if key in rows:
                raise MomaError(
                    f"configuration {key[0]}:{key[1]} of {role} "
                    f"({r['policy']}) is in two runs; the runs must not overlap"
                )
            rows[key] = (int(r["success"]), str(r.get("stage") or ""))
            if role == "model":
                run_of[key] = path
    if not any(role == "model" for role, _ in outcomes):
        raise MomaError("no model rows: give a run of a model beside the oracle and random")
    for name in BASELINES:
        if not any(role == name for role, _ in outcomes):
            raise MomaError(f"no {name} rows: give a run with --method {name}")
    return {"outcomes": outcomes, "run_of": run_of}


def rows(pool: dict[str, Any]) -> list[dict[str, Any]]:
    """One row per model policy (all runs) and per model policy and run."""
    outcomes, run_of = pool["outcomes"], pool["run_of"]
    (oracle,) = [v for (role, _), v in outcomes.items() if role == "oracle"]
    (random,) = [v for (role, _), v in outcomes.items() if role == "random"]
    out = []
    for (role, policy), model in sorted(outcomes.items()):
        if role != "model":
            continue
        for run in [None, *sorted(set(run_of.values()))]:
            keys = sorted(
                k
                for k in model
                if k in oracle and k in random and (run is None or run_of[k] == run)
            )
            if not keys:
                continue
            m, o, r = ([v[k][0] for k in keys] for v in (model, oracle, random))
            rate = {n: sum(x) / len(x) for n, x in (("model", m), ("oracle", o), ("random", r))}
            span = rate["oracle"] - rate["random"]
            out.append(
                {
                    "policy": policy,
                    "run": run or "all",
                    "episodes": len(keys),
                    "success": rate["model"],
                    "oracle": rate["oracle"],
                    "random": rate["random"],
                    "gap_closed": (rate["model"] - rate["random"]) / span if span > 0 else None,
                    "gap_closed_95": gap_closed_interval(m, o, r) if span > 0 else None,
                    "misses": dict(
                        Counter(model[k][1] for k in keys if not model[k][0]).most_common()
                    ),
                }
            )
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", nargs="+", help="approach --json files, each FILE[:METHOD,...]")
    ap.add_argument("--json", type=Path, help="also write the rows here")
    args = ap.parse_args()
    table = rows(pooled([read_run(a) for a in args.runs]))
    for row in table:
        low_high = row["gap_closed_95"]
        gap = "-" if row["gap_closed"] is None else f"{row['gap_closed']:.2f}"
        ci = f" [{low_high[0]:.2f}, {low_high[1]:.2f}]" if low_high else ""
        print(
            f"{row['policy']:<10} {row['run']}: {row['episodes']} episodes, "
            f"{100 * row['success']:.1f} % ({gap}{ci} of the gap; oracle "
            f"{100 * row['oracle']:.1f} %, random {100 * row['random']:.1f} %); misses "
            + ", ".join(f"{k} {v}" for k, v in row["misses"].items())
        )
    if args.json:
        atomic_write_text(args.json, json.dumps(table, indent=1) + "\n")


if __name__ == "__main__":
    run_main(main, "drive_pooled.py")
