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
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from momakitchen.errors import MomaError
from momakitchen.eval.msr import RATE_KEYS
from momakitchen.eval.report.figures import qualitative_figure, qualitative_grid, sweep_figure
from momakitchen.eval.report.tables import (
    MAP_COLUMNS,
    PAIRED_MAP_METRICS,
    PLANNING_POWER,
    ablation_table,
    confidence_table,
    main_table,
    map_breakdown,
    msr_breakdown,
    paired_map_table,
    paired_table,
    per_scene_table,
    pooled_paired_table,
    seed_table,
    sweep_table,
    top1_outcomes,
)
from momakitchen.fileio import (
    atomic_write_bytes,
    atomic_write_text,
    dumps_strict,
    existing_file,
    read_json_object,
)

# The tables and figures live in report_tables and report_figures; importable from here.
__all__ = [
    "BUNDLED",
    "MAP_COLUMNS",
    "PAIRED_MAP_METRICS",
    "PLANNING_POWER",
    "BenchmarkRequest",
    "ablation_table",
    "confidence_table",
    "main_table",
    "map_breakdown",
    "msr_breakdown",
    "paired_map_table",
    "paired_table",
    "per_scene_table",
    "pooled_paired_table",
    "qualitative_figure",
    "qualitative_grid",
    "run_benchmark",
    "run_metrics",
    "seed_table",
    "sweep_figure",
    "sweep_table",
    "top1_outcomes",
]


# The name that stands for the bundled model's run directory among the runs (as
# momakitchen.train.checkpoint.BUNDLED, which this module does not import: it loads torch).
BUNDLED = "bundled"


@dataclass(frozen=True)
class BenchmarkRequest:
    """What ``momakitchen benchmark`` reports on.

    Attributes:
        data: dataset directory (``momakitchen generate``).
        runs: the compared models' run directories (``momakitchen train``), one per model;
            ``bundled`` names the bundled model's (with neither runs nor predictions: the
            bundled model alone).
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
    examples: int = 6
    progress: bool = True

    def __post_init__(self) -> None:
        for name in ("runs", "predictions", "ablations", "sweep", "msr", "seeds", "robustness"):
            object.__setattr__(self, name, tuple(Path(r) for r in getattr(self, name)))
        object.__setattr__(self, "data", Path(self.data))
        object.__setattr__(self, "out", Path(self.out))
        if not self.runs and not self.predictions:  # as msr and robustness: the bundled model
            object.__setattr__(self, "runs", (Path(BUNDLED),))
        if self.runs:  # a shipped model's name (bundled, body) stands for its directory
            from momakitchen.train.checkpoint import resolve_run_dir

            object.__setattr__(self, "runs", tuple(resolve_run_dir(r) for r in self.runs))
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
    text = dumps_strict(report, indent=1, default=float) + "\n"
    out_dir.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out_dir / f"{run.name}.json", text)
    return json.loads(text)  # as read back from a file (string keys), whatever its source


def run_benchmark(req: BenchmarkRequest, log: Callable[[str], None] = print) -> dict[str, Any]:
    """Compute and write the report (see the module docstring). Returns ``benchmark.json``'s
    content."""
    from momakitchen.data import EpisodeDataset
    from momakitchen.data.manifest import load_manifest, split_checksum
    from momakitchen.eval.evaluate import evaluate_predictions
    from momakitchen.eval.methods import BASELINES, CLASSICAL
    from momakitchen.eval.msr import MsrConfig, check_same_views, merge_msr, run_msr
    from momakitchen.eval.predictions import dataset_episodes, load_predictions, method_name
    from momakitchen.eval.robustness.tables import robustness_markdown
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
    if len(set(methods)) != len(methods) or set(methods) & {*BASELINES, *CLASSICAL}:
        raise MomaError(
            f"the compared methods need distinct names, none of {[*BASELINES, *CLASSICAL]}: got "
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
        text = dumps_strict(report, indent=1, default=float) + "\n"
        atomic_write_text(out / "metrics" / f"{name}.json", text)
        metrics[path] = json.loads(text)
    if msr is None:
        log("MSR: models, baselines and the classical methods in closed loop")
        msr = run_msr(
            data,
            [str(r) for r in req.runs],
            [*BASELINES, *CLASSICAL],
            MsrConfig(max_configs=req.max_configs),
            progress=req.progress,
            predictions=[(p, name) for name, p in named.items()],
        )
        atomic_write_text(out / "msr.json", dumps_strict(msr, indent=1) + "\n")
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
    atomic_write_text(out / "benchmark.json", dumps_strict(result, indent=1, default=float) + "\n")
    return result
