"""Robustness results side by side: one row per corruption, Top-1 (all views / views whose
mask kept a target pixel), PCC and SIM of each ``NAME=FILE[,FILE...]:MODEL`` column (a
``momakitchen robustness`` or ``analyses/robustness_before.py`` JSON and the model in it;
several files, e.g. one per ``--seed``, pool their views), as Markdown; then McNemar's test
of the first column against each other one, per corruption (Top-1 per view).

    python analyses/robustness_compare.py \
        before=results/robustness/before-navaff.json:navaff \
        after=results/robustness/after-bundled.json:navaff

The columns must hold the same views (same dataset, seeds and configurations).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from analysis_cli import run_main

from momakitchen.errors import MomaError
from momakitchen.eval.robustness.tables import summarize, top1_by_view
from momakitchen.eval.stats import mcnemar


def _read(path: str, model: str) -> dict:
    if not Path(path).is_file():
        raise MomaError(f"{path!r} does not exist")
    try:
        result = json.loads(Path(path).read_text())
    except json.JSONDecodeError as exc:
        raise MomaError(f"{path!r} is not JSON ({exc})") from None
    if model not in result.get("models", {}):
        raise MomaError(f"{path!r} has no model {model!r} (has {sorted(result.get('models', {}))})")
    return result


def column(spec: str) -> tuple[str, dict, str]:
    """``NAME=FILE[,FILE...]:MODEL`` -> (name, result with the files' records pooled, model)."""
    name, sep, rest = spec.partition("=")
    paths, sep2, model = rest.rpartition(":")
    if not (sep and sep2 and name and paths and model):
        raise MomaError(f"want NAME=FILE[,FILE...]:MODEL, got {spec!r}")
    parts = [_read(p, model) for p in paths.split(",")]
    result = dict(parts[0])
    # each record keeps the seed that chose its view (two seeds may choose one view)
    result["records"] = [
        {**r, "seed": part["config"]["seed"]} for part in parts for r in part["records"]
    ]
    result["config"] = {
        **parts[0]["config"],
        "corruptions": [
            c
            for c in parts[0]["config"]["corruptions"]
            if all(c in p["config"]["corruptions"] for p in parts)
        ],
    }
    return name, result, model


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("columns", nargs="+", metavar="NAME=FILE:MODEL")
    args = ap.parse_args()
    cols = [column(c) for c in args.columns]
    views = {
        tuple(
            (r["seed"], r["scene_id"], r["config_index"], r["episode_index"])
            for r in res["records"]
        )
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
    if len(cols) > 1:
        print()
        print("| McNemar (Top-1 per view) | corruption | views | only first | only second | p |")
        print("| --- | --- | ---: | ---: | ---: | ---: |")
        first_name, first, first_model = cols[0]
        for other_name, other, other_model in cols[1:]:
            for n in names:
                a = top1_by_view(first, first_model, n)
                b = top1_by_view(other, other_model, n)
                keys = sorted(set(a) & set(b))
                only_a, only_b, p = mcnemar([a[k] for k in keys], [b[k] for k in keys])
                print(
                    f"| {first_name} vs {other_name} | {n} | {len(keys)} | {only_a} | "
                    f"{only_b} | {p:.3g} |"
                )


if __name__ == "__main__":
    run_main(main, "robustness_compare.py")
