"""Closed-loop success judged on several views per configuration: `momakitchen msr` results
of other seeds (each seed judges every configuration on another of its first-person views)
pooled per configuration.

    python analyses/msr_views.py --reference navaff --msr \
        results/runs/navaff-12ep/msr.json results/runs/pointnet2-12ep/msr.json \
        results/runs/msr-baselines.json results/runs/views/msr-seed*.json \
        navaff-seed1=results/runs/navaff-12ep-seed1/msr.json \
        navaff-seed1=results/runs/navaff-12ep-seed1/views/msr-seed{1,2,3,4}.json

Files of the same seed are merged (``merge_msr``: same configurations and views); every
seed must cover the same configurations. ``NAME=FILE`` renames the one method of FILE to
NAME, so that two trainings of one model (both called e.g. ``navaff``) can be compared.

Prints each method's Top-1 MSR per seed and over all views; per seed the reference's
McNemar test against each method (as ``benchmark``); pooled over the seeds the
configurations where the reference succeeds on more of the views than the other and on
fewer, with their two-sided sign test (one test per configuration, so the views of a
configuration, which share its kitchen, robot and target, are not counted as independent);
and the difference of the mean Top-1 rates with a 95 % bootstrap interval over
configurations; and each method's rate over all views per target category. Methods missing
from a seed are left out of the pooled figures. ``--pool NAME=M1,M2`` pools methods over
all their views (e.g. two trainings of each model, five views each: ten per configuration)
and compares the first pool with the others the same way.
"""

from __future__ import annotations

import argparse
from collections import Counter, defaultdict
from pathlib import Path

import numpy as np
from analysis_cli import run_main

from momakitchen.errors import MomaError
from momakitchen.eval.msr import merge_msr
from momakitchen.eval.report.tables import pooled_paired_table, top1_outcomes
from momakitchen.eval.stats import mcnemar
from momakitchen.fileio import read_json_object

BOOTSTRAP = 10_000


def read_labelled(arg: str) -> tuple[Path, dict]:
    """The MSR result named by ``FILE`` or ``NAME=FILE`` (its one method renamed NAME)."""
    name, sep, file = arg.partition("=")
    if not sep or Path(arg).exists():
        return Path(arg), read_json_object(Path(arg))
    path = Path(file)
    result = read_json_object(path)
    methods = result.get("methods")
    if not isinstance(methods, dict) or len(methods) != 1:
        found = sorted(methods) if isinstance(methods, dict) else None
        raise MomaError(f"{arg!r}: NAME=FILE needs a result of one method, found {found}")
    (old,) = methods
    try:
        for record in result["records"]:
            record["methods"] = {name: record["methods"][old]}
    except (KeyError, TypeError) as e:
        raise MomaError(f"{str(path)!r} is not a `momakitchen msr` result ({e})") from None
    result["methods"] = {name: methods[old]}
    return path, result


def by_seed(args: list[str]) -> dict[int, dict]:
    """The MSR results merged per seed: {seed: result}, seeds in increasing order."""
    groups: dict[int, list[tuple[str, dict]]] = defaultdict(list)
    for arg in args:
        path, result = read_labelled(arg)
        seed = result.get("config", {}).get("seed")
        if not isinstance(seed, int):
            raise MomaError(f"{str(path)!r} is not a `momakitchen msr` result (no config seed)")
        groups[seed].append((str(path), result))
    merged = {s: merge_msr(groups[s]) for s in sorted(groups)}
    keys = None
    for seed, result in merged.items():
        these = [(r["scene_id"], r["config_index"]) for r in result["records"]]
        if keys is not None and these != keys:
            raise MomaError(f"MSR seed {seed} covers other configurations than seed {min(merged)}")
        keys = these
    return merged


def bootstrap_interval(diff: np.ndarray, seed: int = 0) -> tuple[float, float]:
    """95 % percentile interval of the mean of per-configuration differences ``diff`` (C,),
    resampling configurations."""
    rng = np.random.default_rng(seed)
    idx = rng.integers(len(diff), size=(BOOTSTRAP, len(diff)))
    means = diff[idx].mean(axis=1)
    return float(np.percentile(means, 2.5)), float(np.percentile(means, 97.5))


def print_differences(outcomes: dict[str, list[list[int]]], reference: str) -> None:
    """Difference of Top-1 MSR over all views, ``reference`` minus each other method, with
    its 95 % bootstrap interval over configurations."""
    print(f"\nDifference of Top-1 MSR over all views, {reference} minus the other:\n")
    print("| against | difference | 95 % interval (bootstrap over configurations) |")
    print("| --- | ---: | ---: |")
    ref = np.mean(outcomes[reference], axis=0)
    for m in outcomes:
        if m != reference:
            diff = ref - np.mean(outcomes[m], axis=0)
            lo, hi = bootstrap_interval(diff)
            lo_hi = f"{100 * lo:+.1f} to {100 * hi:+.1f}"
            print(f"| {m} | {100 * diff.mean():+.1f} points | {lo_hi} |")


def make_pools(
    outcomes: dict[str, list[list[int]]], specs: list[str]
) -> dict[str, tuple[list[str], list[list[int]]]]:
    """Each pool ``NAME=M1,M2,...``: {NAME: (its methods, their views together)}."""
    pools = {}
    for spec in specs:
        name, sep, members = spec.partition("=")
        names = members.split(",")
        unknown = [m for m in names if m not in outcomes]
        if not sep or not name or unknown or name in pools:
            raise MomaError(f"--pool {spec!r}: want NAME=M1,M2 of methods {list(outcomes)}")
        pools[name] = (names, [o for m in names for o in outcomes[m]])
    return pools


def print_pools(pools: dict[str, tuple[list[str], list[list[int]]]]) -> None:
    """Each pool's Top-1 MSR over every view of its members; the first pool against each
    other pool of as many views."""
    print("\nPooled, Top-1 MSR over every view of each member:\n")
    print("| pool | members | views per configuration | Top-1 MSR |")
    print("| --- | --- | ---: | ---: |")
    for name, (members, runs) in pools.items():
        print(f"| {name} | {', '.join(members)} | {len(runs)} | {100 * np.mean(runs):.1f} % |")
    views = {name: runs for name, (_, runs) in pools.items()}
    reference, *others = views
    if others:
        print()
        print("\n".join(pooled_paired_table(views, unit="views")))
        print_differences(views, reference)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--msr", nargs="+", required=True, metavar="[NAME=]FILE")
    ap.add_argument("--reference", required=True, help="method compared with every other")
    ap.add_argument(
        "--pool",
        nargs="+",
        default=[],
        metavar="NAME=M1,M2",
        help="also pool methods (e.g. two trainings of one model) over all their views; "
        "the first pool is compared with the others",
    )
    args = ap.parse_args(argv)
    results = by_seed(args.msr)
    seeds = list(results)
    methods = [
        m for m in results[seeds[0]]["methods"] if all(m in r["methods"] for r in results.values())
    ]
    if args.reference not in methods:
        raise MomaError(f"--reference {args.reference!r} is not in every seed; methods: {methods}")
    outcomes = {m: [top1_outcomes(results[s], m) for s in seeds] for m in methods}
    configs = len(outcomes[args.reference][0])
    pools = make_pools(outcomes, args.pool)

    print(f"{configs} configurations, {len(seeds)} views each (MSR seeds {seeds})\n")
    print("| method | " + " | ".join(f"seed {s}" for s in seeds) + " | all views |")
    print("| --- |" + " ---: |" * (len(seeds) + 1))
    for m, runs in outcomes.items():
        cells = [f"{100 * np.mean(o):.1f} %" for o in runs]
        print(f"| {m} | " + " | ".join(cells) + f" | {100 * np.mean(runs):.1f} % |")

    others = [m for m in methods if m != args.reference]
    print(f"\nMcNemar per seed, only {args.reference} / only the other succeeded, p:\n")
    print("| against | " + " | ".join(f"seed {s}" for s in seeds) + " |")
    print("| --- |" + " ---: |" * len(seeds))
    for m in others:
        cells = []
        for a, b in zip(outcomes[args.reference], outcomes[m], strict=True):
            only_a, only_b, p = mcnemar(a, b)
            cells.append(f"{only_a} / {only_b}, {p:.2g}")
        print(f"| {m} | " + " | ".join(cells) + " |")

    print()
    reference_first = {args.reference: outcomes[args.reference], **outcomes}
    print("\n".join(pooled_paired_table(reference_first, unit="views")))
    print_differences(outcomes, args.reference)

    if pools:
        print_pools(pools)

    targets = np.array([r["target"] for r in results[seeds[0]]["records"]])
    views = {m: np.asarray(o) for m, o in outcomes.items()}  # (seeds, configurations)
    print("\nTop-1 MSR over all views per target (largest groups first):\n")
    print("| target | configurations | " + " | ".join(methods) + " |")
    print("| --- | ---: |" + " ---: |" * len(methods))
    for target, count in Counter(targets.tolist()).most_common():
        cells = [f"{100 * views[m][:, targets == target].mean():.1f} %" for m in methods]
        print(f"| {target} | {count} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    run_main(main, "msr_views.py")
