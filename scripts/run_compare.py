"""Two or more trainings compared on the same test bytes, whatever their models: map
metrics per test scene (Wilcoxon) and Top-1 per MSR configuration (McNemar), the first
against each other, as ``momakitchen benchmark`` compares models (which keys runs by model,
so it cannot hold two trainings of one).

    python scripts/run_compare.py mild=results/runs/navaff-12ep-noise-mild \
        renders=results/runs/navaff-12ep/shards-d0d9bfe319af

Each RUN directory holds the ``test.json`` of ``evaluate`` and the ``msr.json`` of ``msr``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from script_cli import run_main

from momakitchen.errors import MomaError
from momakitchen.eval.report import paired_map_table, paired_table


def _load(path: Path) -> dict:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise MomaError(f"cannot read {path}: {exc}") from exc


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", nargs="+", metavar="NAME=RUN")
    args = ap.parse_args()
    if len(args.runs) < 2 or any("=" not in r for r in args.runs):
        raise MomaError(f"give two or more NAME=RUN, got {' '.join(args.runs)}")
    reports, outcomes = [], {}
    for item in args.runs:
        name, run = item.split("=", 1)
        reports.append({**_load(Path(run) / "test.json"), "model": name})
        msr = _load(Path(run) / "msr.json")
        if len(msr["methods"]) != 1:
            raise MomaError(f"{run}/msr.json holds {len(msr['methods'])} methods, expected 1")
        (method,) = msr["methods"]
        outcomes[name] = {
            (r["scene_id"], r["config_index"]): r["methods"][method] for r in msr["records"]
        }
    keys = sorted(set.intersection(*(set(o) for o in outcomes.values())))
    if not keys:
        raise MomaError("the runs' msr.json share no configuration")
    # One MSR result holding every run as a method, on the configurations all of them have.
    merged = {
        "methods": {name: {} for name in outcomes},
        "records": [{"methods": {n: o[k] for n, o in outcomes.items()}} for k in keys],
    }
    print("\n".join(paired_map_table(reports)))
    print()
    print("\n".join(paired_table(merged, next(iter(outcomes)))))


if __name__ == "__main__":
    run_main(main, "run_compare.py")
