"""The benchmark report (``momakitchen benchmark``): the paper's tables and figures for one
generated dataset.

From trained runs, predictions files of methods run elsewhere
(:mod:`momakitchen.eval.predictions`) and the dataset it writes, into one directory:

- ``RESULTS.md``: methods x (RMSE, logMSE, PCC, SIM, cIoU, Top-1 / Top-k MSR), MSR per
  robot and per target category, the ablation table, the per-scene table, the loss-weight
  sweep, the confidence analysis and, with runs of other seeds, each model's mean and
  spread over its seeds and a comparison pooled over them;
- ``qualitative.png`` (ground truth next to every run's map on the same test episodes) and
  ``lambda_sweep.png`` (PCC and RMSE against the loss weight on zero labels);
- ``benchmark.json`` (every number above), ``metrics/`` (one ``evaluate`` report per run)
  and ``msr.json`` when MSR ran here.

Map metrics come from ``RUN/test.json`` when ``momakitchen evaluate`` already wrote it for
this dataset's test split, otherwise the run is evaluated now. MSR covers the main runs and
the ``random``, ``nearest`` and ``oracle`` baselines; earlier ``momakitchen msr`` JSONs can
be passed instead of running it again: one covering every method, or several (e.g. one per
model and one for the baselines) that together do.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

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
from momakitchen.fileio import (
    atomic_write_bytes,
    atomic_write_text,
    existing_file,
    read_json_object,
)

MAP_COLUMNS = (
    ("rmse", "RMSE ↓"),
    ("logmse", "logMSE ↓"),
    ("pcc", "PCC ↑"),
    ("sim", "SIM ↑"),
    ("ciou", "cIoU ↑"),
)


@dataclass(frozen=True)
class BenchmarkRequest:
    """What ``momakitchen benchmark`` reports on.

    Attributes:
        data: dataset directory (``momakitchen generate``).
        runs: the compared models' run directories (``momakitchen train``), one per model.
        out: output directory.
        predictions: predictions files of more compared methods (each named by its file's
            stem), one leaderboard row each, like the runs.
        ablations: runs of ablated models (``navaff-no-*``), compared with the ``navaff`` run
            of ``runs`` on the map metrics.
        sweep: runs that differ only in the loss weight on zero labels (lambda).
        msr: ``momakitchen msr`` JSONs that together cover ``runs`` and the baselines
            (merged with :func:`momakitchen.eval.msr.merge_msr`); empty: run MSR.
        seeds: more runs of models in ``runs``, trained with other seeds, each with its
            ``msr.json`` (``momakitchen msr`` on the same configurations).
        robustness: ``momakitchen robustness`` JSONs (one or more models each): the
            robustness table and McNemar's test of the models under each combination.
        max_configs: MSR on only the first N test configurations (0: all).
        examples: rows of the qualitative figure.
        progress: progress bars.
    """

    data: Path
    runs: tuple[Path, ...]
    out: Path
    predictions: tuple[Path, ...] = ()
    ablations: tuple[Path, ...] = ()
    sweep: tuple[Path, ...] = ()
    msr: tuple[Path, ...] = ()
    seeds: tuple[Path, ...] = ()
    robustness: tuple[Path, ...] = ()
    max_configs: int = 0
    examples: int = 4
    progress: bool = True

    def __post_init__(self) -> None:
        for name in ("runs", "predictions", "ablations", "sweep", "msr", "seeds", "robustness"):
            object.__setattr__(self, name, tuple(Path(r) for r in getattr(self, name)))
        object.__setattr__(self, "data", Path(self.data))
        object.__setattr__(self, "out", Path(self.out))
        if not self.runs and not self.predictions:
            raise MomaError("benchmark needs at least one run (--runs) or --predictions file")
        if not (Path(self.data) / "manifest.json").is_file():
            raise MomaError(f"{str(self.data)!r} is not a dataset directory (no manifest.json)")
        for run in (*self.runs, *self.ablations, *self.sweep, *self.seeds):
            if not (Path(run) / "config.json").is_file():
                raise MomaError(f"{str(run)!r} is not a run directory (no config.json)")
        for path in (*self.msr, *(Path(r) / "msr.json" for r in self.seeds)):
            existing_file(path, "MSR file")
        for path in self.robustness:
            existing_file(path, "robustness file")
        for path in self.predictions:
            existing_file(path, "predictions file")
        if self.max_configs < 0:
            raise MomaError(f"max_configs must be >= 0, got {self.max_configs}")
        if not 1 <= self.examples <= 12:
            raise MomaError(f"examples must be in [1, 12], got {self.examples}")


def run_metrics(
    run: Path, data: Path, test_shards: str, out_dir: Path, progress: bool
) -> dict[str, Any]:
    """The test-split ``evaluate`` report of a run: its ``test.json`` when that was made on
    this dataset (and, where the run records the test shards' checksum in
    ``test-shards.sha256``, on these bytes: ``test_shards``, the dataset's
    :func:`~momakitchen.data.manifest.split_checksum`), else computed now. Either way a copy
    lands in ``out_dir``."""
    from momakitchen.data import EpisodeDataset
    from momakitchen.eval.evaluate import evaluate

    cached = run / "test.json"
    recorded = run / "test-shards.sha256"
    stale = recorded.is_file() and recorded.read_text().strip() != test_shards
    report = None
    if cached.is_file() and not stale:
        try:
            report = json.loads(cached.read_text())
        except json.JSONDecodeError:
            report = None
        if report is not None and (
            report.get("split") != "test"
            or Path(report.get("data", "")).resolve() != data.resolve()
        ):
            report = None
    if report is None:
        report = {
            "data": str(data),
            "split": "test",
            "checkpoint": str(run),
            **evaluate(run, EpisodeDataset(data, "test"), progress=progress),
        }
    text = json.dumps(report, indent=1, default=float) + "\n"
    out_dir.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out_dir / f"{run.name}.json", text)
    return json.loads(text)  # as read back from a file (string keys), whatever its source


def run_benchmark(req: BenchmarkRequest, log: Callable[[str], None] = print) -> dict[str, Any]:
    """Compute and write the report (see the module docstring). Returns ``benchmark.json``'s
    content."""
    from momakitchen.data import EpisodeDataset
    from momakitchen.data.manifest import load_manifest, split_checksum
    from momakitchen.eval.evaluate import evaluate_predictions
    from momakitchen.eval.msr import BASELINES, MsrConfig, check_same_views, merge_msr, run_msr
    from momakitchen.eval.predictions import dataset_episodes, load_predictions, method_name
    from momakitchen.eval.robustness import robustness_markdown
    from momakitchen.train.checkpoint import load_checkpoint

    data, out = req.data, req.out
    # A run may serve twice (the navaff run is also the sweep's lambda = 0.7 point).
    every = tuple(dict.fromkeys((*req.runs, *req.ablations, *req.sweep, *req.seeds)))
    names = [r.name for r in every]
    if len(set(names)) != len(names):
        raise MomaError(f"run directories need distinct names, got {names}")
    configs = {r: load_checkpoint(r).config for r in every}
    models = [configs[r].model for r in req.runs]
    if len(set(models)) != len(models):
        raise MomaError(f"--runs need one run per model, got models {models}")
    # Methods run elsewhere, named by their files; one leaderboard row each, as a run's.
    stems = [method_name(p) for p in req.predictions]
    named = dict(zip(stems, req.predictions, strict=True))
    methods = [*models, *stems]
    if len(set(methods)) != len(methods) or set(methods) & set(BASELINES):
        raise MomaError(
            f"the compared methods need distinct names, none of {list(BASELINES)}: got "
            f"{methods} (a --predictions file is named by its stem: rename the file)"
        )
    if req.ablations and "navaff" not in models:
        raise MomaError("the ablation table needs a navaff run among --runs")
    for r in req.seeds:
        if configs[r].model not in models:
            raise MomaError(f"seed run {str(r)!r} is a {configs[r].model} run, not among {models}")
    seed_msr = {r: read_json_object(r / "msr.json") for r in req.seeds}
    for r, m in seed_msr.items():
        if configs[r].model not in m.get("methods", {}):
            raise MomaError(f"{str(r / 'msr.json')!r} has no {configs[r].model} results")
    msr = None
    if req.msr:  # checked before any map metric is computed: bad files fail at once
        msr = merge_msr([(str(p), read_json_object(p)) for p in req.msr])
        missing = [m for m in (*methods, *BASELINES) if m not in msr["methods"]]
        if missing:
            files = ", ".join(repr(str(p)) for p in req.msr)
            raise MomaError(f"MSR files {files} lack methods {missing}")
    robustness = [read_json_object(p) for p in req.robustness]
    for path, res in zip(req.robustness, robustness, strict=True):
        if not isinstance(res.get("models"), dict) or "records" not in res:
            raise MomaError(f"{str(path)!r} is not a `momakitchen robustness` result")
    test_data = EpisodeDataset(data, "test")
    for path in named.values():  # every file read and checked before any work
        load_predictions(path, dataset_episodes(test_data))
    test_shards = split_checksum(load_manifest(data), "test")  # keys reusable test.json
    out.mkdir(parents=True, exist_ok=True)

    t0 = time.perf_counter()
    metrics = {}
    for r in every:
        log(f"map metrics: {r}")
        metrics[r] = run_metrics(r, data, test_shards, out / "metrics", req.progress)
    for name, path in named.items():
        log(f"map metrics: {path}")
        report = {
            "data": str(data),
            "split": "test",
            **evaluate_predictions(path, test_data, name, progress=req.progress),
        }
        (out / "metrics").mkdir(parents=True, exist_ok=True)
        text = json.dumps(report, indent=1, default=float) + "\n"
        atomic_write_text(out / "metrics" / f"{name}.json", text)
        metrics[path] = json.loads(text)
    if msr is None:
        log("MSR: models and baselines in closed loop")
        msr = run_msr(
            data,
            [str(r) for r in req.runs],
            list(BASELINES),
            MsrConfig(max_configs=req.max_configs),
            progress=req.progress,
            predictions=[(p, name) for name, p in named.items()],
        )
        atomic_write_text(out / "msr.json", json.dumps(msr, indent=1) + "\n")
    for r, m in seed_msr.items():
        check_same_views(("MSR", msr), (str(r / "msr.json"), m))

    main_reports = [metrics[r] for r in (*req.runs, *named.values())]
    lines = ["## Methods", "", *main_table(main_reports, msr), "", *msr_breakdown(msr)]
    if robustness:
        lines += ["", "## Robustness to real sensors", "", *robustness_markdown(robustness)]
    lines += ["", *map_breakdown(main_reports)]
    lines += ["", f"### {methods[0]} against each method", "", *paired_table(msr, methods[0])]
    if len(main_reports) > 1:
        lines += ["", *paired_map_table(main_reports)]
    if req.seeds:
        groups = {
            m: [(metrics[r], top1_outcomes(msr, m))] for r, m in zip(req.runs, models, strict=True)
        }
        for r in req.seeds:
            model = configs[r].model
            groups[model].append((metrics[r], top1_outcomes(seed_msr[r], model)))
        lines += ["", "## Seeds", "", *seed_table(groups)]
        pooled = pooled_paired_table({m: [o for _, o in g] for m, g in groups.items()})
        lines += ["", *pooled] if pooled else []
    if req.ablations:
        full = metrics[req.runs[models.index("navaff")]]
        lines += [
            "",
            "## Ablations",
            "",
            *ablation_table(full, [metrics[r] for r in req.ablations]),
        ]
    lines += ["", "## Per scene", "", *per_scene_table(main_reports, msr)]
    sweep = sorted(
        ((configs[r].model_config.lambda_zero, metrics[r]) for r in req.sweep), key=lambda t: t[0]
    )
    if sweep:
        atomic_write_bytes(out / "lambda_sweep.png", sweep_figure(sweep))
        lines += [
            "",
            "## Loss weight",
            "",
            *sweep_table(sweep, configs, req.sweep),
            "",
            "![PCC and RMSE against lambda](lambda_sweep.png)",
        ]
    confident = [
        name
        for name in msr["methods"]
        if any("uncertainty" in r["methods"][name] for r in msr["records"])
    ]
    if confident:
        lines += ["", "## Confidence"]
        for name in confident:
            lines += ["", *confidence_table(msr, name)]
    log("qualitative figure")
    figure = qualitative_figure(data, req.runs, req.examples, [(n, p) for n, p in named.items()])
    atomic_write_bytes(out / "qualitative.png", figure)
    lines += [
        "",
        "## Examples",
        "",
        "Ground truth and each model's map on the same test episodes:",
        "",
        "![qualitative](qualitative.png)",
    ]
    atomic_write_text(out / "RESULTS.md", "# Benchmark\n\n" + "\n".join(lines) + "\n")
    result = {
        "data": str(data),
        "runs": {
            str(r): {k: metrics[r][k] for k in ("model", "metrics")}
            for r in (*req.runs, *req.ablations, *req.seeds)
        },
        "predictions": {
            str(p): {k: metrics[p][k] for k in ("model", "metrics")} for p in named.values()
        },
        "sweep": [{"lambda_zero": lam, "metrics": rep["metrics"]} for lam, rep in sweep],
        "msr": {name: {k: s[k] for k in RATE_KEYS} for name, s in msr["methods"].items()},
        "msr_configurations": msr["configurations"],
        "seconds": round(time.perf_counter() - t0, 1),
    }
    atomic_write_text(out / "benchmark.json", json.dumps(result, indent=1, default=float) + "\n")
    return result


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


def sweep_figure(sweep: Sequence[tuple[float, dict]]) -> bytes:
    """PCC and RMSE against lambda (two panels), as PNG bytes."""
    from momakitchen.perception.figures import png_bytes, pyplot

    plt = pyplot()
    lam = [s[0] for s in sweep]
    fig, axes = plt.subplots(1, 2, figsize=(8, 3.2), constrained_layout=True)
    for ax, key, label in zip(axes, ("pcc", "rmse"), ("PCC ↑", "RMSE ↓"), strict=True):
        ax.plot(lam, [s[1]["metrics"][key] for s in sweep], "o-", color="tab:blue")
        ax.set_xlabel("λ (weight on zero-valued labels)")
        ax.set_title(label)
        ax.grid(alpha=0.3)
    return png_bytes(fig)


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

    def success(m: np.ndarray) -> str:
        return f"{ok[m].mean():.0%} ({m.sum()})" if m.any() else "– (0)"

    for t, label in enumerate(("low", "middle", "high")):
        a_in, u_in = inside(aff, a_edges, t), inside(unc, u_edges, t)
        out.append(
            f"| {label} | {a_edges[t]:.2f}–{a_edges[t + 1]:.2f} | {success(a_in)} | "
            f"{u_edges[t]:.3f}–{u_edges[t + 1]:.3f} | {success(u_in)} |"
        )
    return out


def qualitative_figure(
    data_dir: Path,
    runs: Sequence[Path],
    examples: int,
    predictions: Sequence[tuple[str, Path]] = (),
) -> bytes:
    """Ground truth and every run's and predictions file's (``(name, file)``) map on the
    same test episodes: the last view of the first ``examples`` test configurations that
    have a successful trial. PNG bytes."""
    from momakitchen.data import EpisodeDataset
    from momakitchen.eval.predictions import dataset_episodes, load_predictions
    from momakitchen.models.inference import inference_collator, predict_batch
    from momakitchen.perception.figures import png_bytes
    from momakitchen.train.checkpoint import load_checkpoint

    data = EpisodeDataset(data_dir, "test")
    last_view: dict[tuple[int, int], int] = {}
    for i, (_, sid, c, _e, _) in enumerate(data.index):
        last_view[(sid, c)] = i
    picked = []
    for i in last_view.values():
        sample = data[i]
        if float(sample["floor_label"].max()) > 0.5:
            picked.append(sample)
        if len(picked) == examples:
            break
    if not picked:
        raise MomaError(f"no test configuration of {str(data_dir)!r} has a successful trial")
    loaded = [load_checkpoint(r) for r in runs]
    stored = [
        load_predictions(path, dataset_episodes(data), name).maps for name, path in predictions
    ]
    rows = []
    for sample in picked:
        maps = []
        for run in loaded:
            batch = inference_collator(run.config)([sample])
            maps.append((run.config.model, predict_batch(run.model, batch)[0].numpy()))
        key = f"{sample['scene_id']}/{sample['config_index']}/{sample['episode_index']}"
        maps += [(name, m[key]) for (name, _), m in zip(predictions, stored, strict=True)]
        title = f"ground truth: scene {sample['scene_id']}, {sample['robot_name']}"
        rows.append((title, sample["floor_xyz"].numpy(), sample["floor_label"].numpy(), maps))
    fig = qualitative_grid(rows)
    return png_bytes(fig)


def qualitative_grid(
    rows: Sequence[tuple[str, np.ndarray, np.ndarray, Sequence[tuple[str, np.ndarray]]]],
) -> Any:
    """The figure of :func:`qualitative_figure`: per row (title, floor points (N, 3), the
    ground truth (N,), [(model name, its map (N,))]) the ground truth and every map, all on
    one 0-1 colour scale with one colour bar, so that a model whose map peaks at
    0.06 looks as unsure as it is (each map's maximum is in its title)."""
    from momakitchen.perception.figures import floor_map, pyplot

    plt = pyplot()
    columns = 1 + max(len(maps) for *_, maps in rows)
    fig, axes = plt.subplots(
        len(rows),
        columns,
        figsize=(3.6 * columns + 0.8, 3.2 * len(rows)),
        constrained_layout=True,
        squeeze=False,
    )
    scatter = None
    for row, (title, xyz, label, maps) in enumerate(rows):
        scatter = floor_map(axes[row, 0], xyz, label, title, vmax=1.0)
        for col, (name, pred) in enumerate(maps, start=1):
            floor_map(axes[row, col], xyz, pred, f"{name} (max {pred.max():.2f})", vmax=1.0)
    fig.colorbar(scatter, ax=axes.ravel().tolist(), shrink=0.6, label="affordance (0–1)")
    return fig
