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
from pathlib import Path

from script_cli import run_main

from momakitchen.errors import MomaError
from momakitchen.eval.msr import merge_msr
from momakitchen.eval.report.tables import paired_map_table, paired_table
from momakitchen.fileio import read_json_object


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", nargs="+", metavar="NAME=RUN")
    args = ap.parse_args()
    if len(args.runs) < 2 or any("=" not in r for r in args.runs):
        raise MomaError(f"give two or more NAME=RUN, got {' '.join(args.runs)}")
    reports, parts = [], []
    for item in args.runs:
        name, run = item.split("=", 1)
        reports.append({**read_json_object(Path(run) / "test.json"), "model": name})
        msr = read_json_object(Path(run) / "msr.json")
        methods = msr.get("methods", {})
        if len(methods) != 1:
            raise MomaError(f"{run}/msr.json holds {len(methods)} methods, expected 1")
        # Each run's one method renamed to its NAME, so merge_msr pairs them view by view.
        (method,) = methods
        msr["methods"] = {name: methods[method]}
        for rec in msr.get("records", []):
            rec["methods"] = {name: rec["methods"][method]}
        parts.append((f"{run}/msr.json", msr))
    merged = merge_msr(parts)
    print("\n".join(paired_map_table(reports)))
    print()
    print("\n".join(paired_table(merged, next(iter(merged["methods"])))))


if __name__ == "__main__":
    run_main(main, "run_compare.py")
