"""Robustness results side by side: one row per corruption, Top-1 (all views / views whose
mask kept a target pixel), PCC and SIM of each ``NAME=FILE:MODEL`` column (a ``momakitchen
robustness`` or ``scripts/robustness_before.py`` JSON and the model in it), as Markdown.

    python scripts/robustness_compare.py \
        before=results/robustness/before-navaff.json:navaff \
        after=results/robustness/after-bundled.json:navaff

The columns must hold the same views (same dataset, seed and configurations).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from script_cli import run_main

from momakitchen.errors import MomaError
from momakitchen.eval.robustness import summarize


def column(spec: str) -> tuple[str, dict, str]:
    """``NAME=FILE:MODEL`` -> (name, result, model)."""
    name, sep, rest = spec.partition("=")
    path, sep2, model = rest.rpartition(":")
    if not (sep and sep2 and name and path and model):
        raise MomaError(f"want NAME=FILE:MODEL, got {spec!r}")
    if not Path(path).is_file():
        raise MomaError(f"{path!r} does not exist")
    try:
        result = json.loads(Path(path).read_text())
    except json.JSONDecodeError as exc:
        raise MomaError(f"{path!r} is not JSON ({exc})") from None
    if model not in result.get("models", {}):
        raise MomaError(f"{path!r} has no model {model!r} (has {sorted(result.get('models', {}))})")
    return name, result, model


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("columns", nargs="+", metavar="NAME=FILE:MODEL")
    args = ap.parse_args()
    cols = [column(c) for c in args.columns]
    views = {
        tuple((r["scene_id"], r["config_index"], r["episode_index"]) for r in res["records"])
        for _, res, _ in cols
    }
    if len(views) != 1:
        raise MomaError("the files do not hold the same views (dataset, seed, configurations)")
    names = [
        n
        for n in cols[0][1]["config"]["corruptions"]
        if all(n in res["config"]["corruptions"] for _, res, _ in cols)
    ]
    head = "| corruption |" + "".join(
        f" {c} Top-1 | {c} Top-1, usable masks | {c} PCC | {c} SIM | errors ({c}) |"
        for c, _, _ in cols
    )
    print(head)
    print("| --- |" + " ---: | ---: | ---: | ---: | --- |" * len(cols))
    for n in names:
        cells = []
        for _, res, model in cols:
            s = summarize(res["records"], model, n)
            errors = ", ".join(f"{k} {v}" for k, v in s["errors"].items()) or "0"
            cells.append(
                f" {s['top1'] * 100:.1f} | {s['top1_usable'] * 100:.1f} | {s['pcc']:.3f} | "
                f"{s['sim']:.3f} | {errors} |"
            )
        print(f"| {n} |" + "".join(cells))


if __name__ == "__main__":
    run_main(main, "robustness_compare.py")
