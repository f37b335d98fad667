"""The benchmark report's tables (``momakitchen benchmark``'s ``RESULTS.md``): Markdown
lines built from ``evaluate`` reports and ``msr`` results."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from momakitchen.errors import MomaError
from momakitchen.eval.msr import RATE_KEYS
from momakitchen.eval.stats import (
    auroc,
    detectable_lead,
    mcnemar,
    sign_test,
    signed_rank_test,
)

MAP_COLUMNS = (
    ("rmse", "RMSE ↓"),
    ("logmse", "logMSE ↓"),
    ("pcc", "PCC ↑"),
    ("sim", "SIM ↑"),
    ("ciou", "cIoU ↑"),
)


def _row(cells: Sequence[str]) -> str:
    return "| " + " | ".join(cells) + " |"


def main_table(reports: Sequence[dict], msr: dict) -> list[str]:
    """Methods x map metrics and MSR; baselines without maps get dashes."""
    k = msr["config"]["top_k"]
    head = [
        "method",
        *(c for _, c in MAP_COLUMNS),
        "Top-1 MSR ↑",
        f"Top-{k} MSR ↑",
        "Top-1 (feasible)",
        f"Top-{k} (feasible)",
    ]
    lines = [_row(head), "|---" * len(head) + "|"]

    def rates(name: str) -> list[str]:
        s = msr["methods"].get(name)
        return [f"{100 * s[key]:.1f} %" if s else "–" for key in RATE_KEYS]

    for rep in reports:
        lines.append(
            _row(
                [
                    rep["model"],
                    *(f"{rep['metrics'][key]:.4f}" for key, _ in MAP_COLUMNS),
                    *rates(rep["model"]),
                ]
            )
        )
    for name in msr["methods"]:
        if name not in {r["model"] for r in reports}:
            lines.append(_row([name, *("–" for _ in MAP_COLUMNS), *rates(name)]))
    return [
        *lines,
        "",
        f"Map metrics on {reports[0]['episodes']} test episodes. MSR on "
        f"{msr['configurations']} {msr['config']['split']} configurations "
        f"({msr['feasible_configurations']} with at least one successful grid "
        f"trial: 'feasible'), seed {msr['config']['seed']}.",
    ]


PLANNING_POWER = 0.8  # the power the benchmark's closed-loop table plans for


def top1_outcomes(msr: dict, name: str) -> list[int]:
    """Top-1 outcome (1/0) of a method on every MSR configuration, in record order (a
    configuration where it chose nothing counts as a failure)."""
    return [int(bool(o[0])) if (o := r["methods"][name]["outcomes"]) else 0 for r in msr["records"]]


def _mean_sd(values: Sequence[float], digits: int) -> str:
    if len(values) < 2:
        return f"{values[0]:.{digits}f}"
    return f"{np.mean(values):.{digits}f} ± {np.std(values, ddof=1):.{digits}f}"


def seed_table(groups: dict[str, list[tuple[dict, list[int]]]]) -> list[str]:
    """Each model's mean ± sample standard deviation over its runs (one per seed) of the
    map metrics of :data:`PAIRED_MAP_METRICS` and Top-1 MSR; ``groups``: model -> (its
    ``evaluate`` report, its Top-1 outcomes) per run."""
    columns = dict(MAP_COLUMNS)
    head = ["method", "runs", *(columns[k] for k in PAIRED_MAP_METRICS), "Top-1 MSR ↑"]
    lines = [_row(head), "|---" * len(head) + "|"]
    for model, runs in groups.items():
        top1 = [100 * float(np.mean(o)) for _, o in runs]
        cells = [_mean_sd([rep["metrics"][k] for rep, _ in runs], 4) for k in PAIRED_MAP_METRICS]
        lines.append(_row([model, str(len(runs)), *cells, _mean_sd(top1, 1) + " %"]))
    return [*lines, "", "Mean ± sample standard deviation over each model's runs."]


def pooled_paired_table(outcomes: dict[str, list[list[int]]], unit: str = "runs") -> list[str]:
    """The first model against every other with as many runs, Top-1, pooled over each
    model's runs: per configuration the number of its runs that succeeded; the
    configurations where each is ahead, and the two-sided sign test of those counts.
    (With unequal numbers of runs the difference is not symmetric under the null.)
    ``unit`` names what the outcome lists are in the caption (runs, or views)."""
    wins = {m: np.sum(np.asarray(o, int), axis=0) for m, o in outcomes.items()}
    reference, *others = wins
    runs = len(outcomes[reference])
    others = [m for m in others if len(outcomes[m]) == runs]
    if not others:
        return []
    lines = [
        _row(["against", f"{reference} ahead", "the other ahead", "p (sign test)"]),
        "|---|---|---|---|",
    ]
    for name in others:
        d = wins[reference] - wins[name]
        ahead, behind = int((d > 0).sum()), int((d < 0).sum())
        p = sign_test(ahead, behind)
        lines.append(_row([name, str(ahead), str(behind), f"{p:.2g}"]))
    return [
        *lines,
        "",
        f"Configurations where more of {reference}'s {runs} {unit} succeed at Top-1 than of "
        f"the other's, and fewer; models with as many {unit} only.",
    ]


def paired_table(msr: dict, reference: str) -> list[str]:
    """``reference`` against every other MSR method, Top-1, paired by configuration, with the
    least lead the test would find with ``PLANNING_POWER`` on these configurations."""
    ref = top1_outcomes(msr, reference)
    n = len(ref)
    power = f"{100 * PLANNING_POWER:.0f} % power"
    head = ["against", f"only {reference} succeeded", "only the other succeeded", "p (McNemar)"]
    lines = [_row([*head, f"least detectable lead ({power})"]), "|---|---|---|---|---|"]
    for name in msr["methods"]:
        if name != reference:
            only_a, only_b, p = mcnemar(ref, top1_outcomes(msr, name))
            discordant = (only_a + only_b) / n
            lead = detectable_lead(n, discordant, PLANNING_POWER) if discordant else np.nan
            cell = "none" if np.isnan(lead) else f"{100 * lead:.1f} points"
            lines.append(_row([name, str(only_a), str(only_b), f"{p:.2g}", cell]))
    return [
        *lines,
        "",
        f"Top-1 outcomes on the same {n} configurations; the exact two-sided test of the "
        "discordant pairs. The last column: the least true lead, of either method, that the "
        f"test would find with {power} with as many configurations solved by only one of the "
        "two (not a measured lead).",
    ]


# Map metrics compared scene by scene (names and directions from MAP_COLUMNS).
PAIRED_MAP_METRICS = ("pcc", "sim", "rmse", "ciou")


def paired_map_table(reports: Sequence[dict]) -> list[str]:
    """The first run against every other on the map metrics, paired by test scene: the
    scenes where the first is better, and the two-sided Wilcoxon signed-rank p-value of the
    per-scene differences."""
    ref = reports[0]
    scenes = sorted(ref["per_scene"], key=int)
    columns = dict(MAP_COLUMNS)
    head = [
        "against",
        *(f"{columns[k].split()[0]}: scenes {ref['model']} better, p" for k in PAIRED_MAP_METRICS),
    ]
    lines = [_row(head), "|---" * len(head) + "|"]
    for other in reports[1:]:
        if sorted(other["per_scene"], key=int) != scenes:
            raise MomaError(f"runs {ref['model']} and {other['model']} cover different scenes")
        cells = [other["model"]]
        for key in PAIRED_MAP_METRICS:
            d = np.array([ref["per_scene"][s][key] - other["per_scene"][s][key] for s in scenes])
            d = -d if columns[key].endswith("↓") else d  # > 0: the first run is better
            p = signed_rank_test(d)
            cells.append(f"{int((d > 0).sum())} of {len(d)}, {p:.2g}")
        lines.append(_row(cells))
    return [
        *lines,
        "",
        f"Map metrics per test scene (mean over its episodes), {ref['model']} against each "
        "run; p: Wilcoxon signed-rank test of the per-scene differences, two-sided.",
    ]


def msr_breakdown(msr: dict) -> list[str]:
    """Top-1 MSR per robot (with configuration counts) and per target category."""
    robots = sorted({r for s in msr["methods"].values() for r in s["per_robot"]})
    lines = [_row(["Top-1 MSR per robot", *robots]), "|---" * (len(robots) + 1) + "|"]
    for name, s in msr["methods"].items():
        lines.append(
            _row(
                [
                    name,
                    *(
                        f"{100 * s['per_robot'][r]['top1']:.0f} % "
                        f"({s['per_robot'][r]['configurations']})"
                        if r in s["per_robot"]
                        else "–"
                        for r in robots
                    ),
                ]
            )
        )
    cats = sorted({c for s in msr["methods"].values() for c in s["per_category"]})
    lines += ["", _row(["Top-1 MSR per target", *cats]), "|---" * (len(cats) + 1) + "|"]
    for name, s in msr["methods"].items():
        lines.append(
            _row(
                [
                    name,
                    *(
                        f"{100 * s['per_category'][c]['top1']:.0f} %"
                        if c in s["per_category"]
                        else "–"
                        for c in cats
                    ),
                ]
            )
        )
    return lines


def map_breakdown(reports: Sequence[dict]) -> list[str]:
    """PCC / SIM of each run per robot and per target category (the latter where every
    report has it: ``evaluate`` on a dataset whose manifest names the targets)."""
    lines: list[str] = []
    for key, title in (("per_robot", "robot"), ("per_category", "target")):
        if not all(key in r for r in reports):
            continue
        groups = sorted({g for r in reports for g in r[key]})
        if lines:
            lines.append("")
        lines += [_row([f"PCC / SIM per {title}", *groups]), "|---" * (len(groups) + 1) + "|"]
        for r in reports:
            cells = [
                f"{r[key][g]['pcc']:.2f} / {r[key][g]['sim']:.2f}" if g in r[key] else "–"
                for g in groups
            ]
            lines.append(_row([r["model"], *cells]))
    return lines


def ablation_table(full: dict, ablations: Sequence[dict]) -> list[str]:
    """The full model and its ablations on the map metrics, with the change in PCC."""
    from momakitchen.models.registry import get_model_entry

    head = ["model", "removes", *(c for _, c in MAP_COLUMNS), "Δ PCC"]
    lines = [_row(head), "|---" * len(head) + "|"]
    for rep in (full, *ablations):
        removed = "–" if rep is full else get_model_entry(rep["model"]).description
        lines.append(
            _row(
                [
                    rep["model"],
                    removed,
                    *(f"{rep['metrics'][key]:.4f}" for key, _ in MAP_COLUMNS),
                    f"{rep['metrics']['pcc'] - full['metrics']['pcc']:+.4f}",
                ]
            )
        )
    return lines


def per_scene_table(reports: Sequence[dict], msr: dict) -> list[str]:
    """Per test scene: each run's RMSE and PCC, and every MSR method's Top-1 rate."""
    methods = list(msr["methods"])
    top1: dict[str, dict[str, list[int]]] = {}
    for r in msr["records"]:
        for name in methods:
            o = r["methods"][name]["outcomes"]
            top1.setdefault(str(r["scene_id"]), {}).setdefault(name, []).append(o[0] if o else 0)
    head = [
        "scene",
        "episodes",
        *(f"{r['model']} RMSE / PCC" for r in reports),
        *(f"{m} Top-1" for m in methods),
    ]
    out = [
        "Map metrics over each scene's episodes; MSR over its configurations.",
        "",
        _row(head),
        "|---" * len(head) + "|",
    ]
    for scene in sorted(reports[0]["per_scene"], key=int):
        cells = [scene, str(int(reports[0]["per_scene"][scene]["episodes"]))]
        cells += [
            f"{r['per_scene'][scene]['rmse']:.3f} / {r['per_scene'][scene]['pcc']:.2f}"
            for r in reports
        ]
        cells += [f"{np.mean(top1[scene][m]):.0%}" if scene in top1 else "–" for m in methods]
        out.append(_row(cells))
    return out


def sweep_table(
    sweep: Sequence[tuple[float, dict]], configs: dict, runs: Sequence[Path]
) -> list[str]:
    cfgs = [configs[r] for r in runs]
    schedules = sorted(
        {f"{c.max_steps} steps" if c.max_steps else f"{c.epochs} epoch(s)" for c in cfgs}
    )
    lines = [
        f"Runs that differ only in λ, the loss weight on zero-valued labels (applied on a "
        f"random half of the steps); trained for {', '.join(schedules)}.",
        "",
        _row(["λ", *(c for _, c in MAP_COLUMNS)]),
        "|---" * (len(MAP_COLUMNS) + 1) + "|",
    ]
    for lam, rep in sweep:
        lines.append(_row([f"{lam:g}", *(f"{rep['metrics'][key]:.4f}" for key, _ in MAP_COLUMNS)]))
    return lines


def confidence_table(msr: dict, name: str) -> list[str]:
    """Does the model's confidence at its Top-1 point predict the trial's outcome?"""
    rows = [r["methods"][name] for r in msr["records"] if r["methods"][name]["outcomes"]]
    ok = np.array([r["outcomes"][0] for r in rows])
    aff = np.array([r["affordance"][0] for r in rows])
    unc = np.array([r["uncertainty"][0] for r in rows])
    out = [
        f"Confidence of {name} at its Top-1 point vs the trial outcome ({len(rows)} "
        f"configurations, {ok.mean():.0%} succeeded). AUROC (0.5 = no signal): predicted "
        f"affordance {auroc(aff, ok):.2f}; low uncertainty {auroc(-unc, ok):.2f}; low relative "
        f"uncertainty (std / affordance) {auroc(-unc / np.maximum(aff, 1e-3), ok):.2f}.",
        "",
        "| tercile | affordance range | success | uncertainty range | success |",
        "|---|---|---|---|---|",
    ]
    qs = [0, 1 / 3, 2 / 3, 1]
    a_edges, u_edges = np.quantile(aff, qs), np.quantile(unc, qs)

    def inside(v: np.ndarray, edges: np.ndarray, t: int) -> np.ndarray:
        return (v >= edges[t]) & ((v <= edges[t + 1]) if t == 2 else (v < edges[t + 1]))

    def cells(v: np.ndarray, edges: np.ndarray, t: int, digits: int) -> tuple[str, str]:
        m = inside(v, edges, t)
        if not m.any():  # tied values (a flat map) leave a tercile empty
            return "–", "no configurations"
        span = f"{edges[t]:.{digits}f}–{edges[t + 1]:.{digits}f}"
        return span, f"{ok[m].mean():.0%} ({m.sum()})"

    skipped = 0
    for t, label in enumerate(("low", "middle", "high")):
        a_span, a_ok = cells(aff, a_edges, t, 2)
        u_span, u_ok = cells(unc, u_edges, t, 3)
        if a_span == u_span == "–":
            skipped += 1
            continue
        out.append(f"| {label} | {a_span} | {a_ok} | {u_span} | {u_ok} |")
    if skipped:
        out += ["", f"Terciles without any configuration (tied values) left out: {skipped}."]
    return out
