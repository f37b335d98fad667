"""``momakitchen benchmark``: the paper's tables and figures for a generated dataset.

Map metrics of every run and predictions file on the test split (reusing ``RUN/test.json``
from ``evaluate`` when present), closed-loop MSR of the main runs, the predictions files
and the random / nearest / oracle baselines, the ablation table, the per-scene table, the
loss-weight (lambda) sweep, a qualitative figure and, with ``--seeds``, each model's
spread over its seeds, written as ``RESULTS.md`` with its PNGs and ``benchmark.json``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from momakitchen.cli.common import positive_int
from momakitchen.cli.options import add_data, add_max_configs, add_quiet, add_robot_yaml


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "benchmark", help="results tables and figures (RESULTS.md)", description=__doc__
    )
    add_data(p)
    p.add_argument(
        "--runs",
        nargs="+",
        default=[],
        metavar="RUN",
        help="run directories of the compared models (one per model); 'bundled', 'body': a "
        "shipped model (default with no --predictions: the bundled model alone)",
    )
    p.add_argument(
        "--predictions",
        nargs="+",
        default=[],
        metavar="FILE",
        help="predictions files of methods run elsewhere (.npz or .h5 of the test split, "
        "docs/METHODS.md), each named by its file's stem: one row each, like a run",
    )
    p.add_argument(
        "--ablations",
        nargs="+",
        default=[],
        metavar="RUN",
        help="runs of navaff-no-* models (compared with the navaff run)",
    )
    p.add_argument(
        "--sweep",
        nargs="+",
        default=[],
        metavar="RUN",
        help="runs that differ only in --lambda-zero",
    )
    p.add_argument(
        "--msr",
        nargs="+",
        default=[],
        metavar="JSON",
        help="reuse `momakitchen msr` results that together cover --runs and the "
        "baselines (e.g. one per run and one for the baselines)",
    )
    p.add_argument(
        "--seeds",
        nargs="+",
        default=[],
        metavar="RUN",
        help="more runs of models in --runs, trained with other seeds, each with its "
        "msr.json: each model's mean and spread over its runs, and a test pooled over them",
    )
    p.add_argument(
        "--robustness",
        nargs="+",
        default=[],
        metavar="JSON",
        help="`momakitchen robustness` results: a robustness table, and McNemar's test of "
        "the models under each combined corruption",
    )
    add_max_configs(p)
    p.add_argument(
        "--examples",
        type=positive_int,
        default=6,
        help="rows of the qualitative figure (6: every robot)",
    )
    p.add_argument("--out", required=True, help="output directory")
    add_quiet(p)
    add_robot_yaml(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from momakitchen.cli.common import output_dir
    from momakitchen.eval.report.benchmark import BenchmarkRequest, run_benchmark

    req = BenchmarkRequest(
        data=Path(args.data),
        runs=tuple(map(Path, args.runs)),
        out=Path(args.out),
        predictions=tuple(map(Path, args.predictions)),
        ablations=tuple(map(Path, args.ablations)),
        sweep=tuple(map(Path, args.sweep)),
        msr=tuple(map(Path, args.msr)),
        robustness=tuple(map(Path, args.robustness)),
        seeds=tuple(map(Path, args.seeds)),
        max_configs=args.max_configs,
        examples=args.examples,
        progress=not args.quiet,
    )
    output_dir(args.out)
    result = run_benchmark(req)
    print(f"{result['seconds']:.0f} s -> {Path(args.out) / 'RESULTS.md'}")
    return 0
