"""``momakitchen msr``: closed-loop manipulation success rate of models and baselines.

For every configuration of a split the world is rebuilt, each method picks base positions
on one first-person view (Top-1 and Top-k, spread apart), and the robot runs the
labelling's trial there in physics. Prints a table and writes the rates (overall, per
robot, per target category) and every trial's point and outcome as JSON.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from momakitchen.cli.common import (
    add_robot_yaml,
    checked_methods,
    non_negative_float,
    non_negative_int,
    output_file,
    positive_int,
)
from momakitchen.errors import MomaError
from momakitchen.fileio import atomic_write_text, dumps_strict

# momakitchen.eval.msr's BASELINES and SPLITS, spelled out so that building the parser
# (``momakitchen --help``) does not import numpy and h5py; tests/cli/test_main.py checks.
BASELINES = ("random", "nearest", "oracle")
SPLITS = ("test", "train", "all")


def _named_checkpoint(text: str) -> str | tuple[str, str]:
    """``RUN`` or ``NAME=RUN`` (a directory whose own name holds ``=`` stays a path)."""
    name, sep, run = text.partition("=")
    if not sep or Path(text).exists():
        return text
    if not name or not run:
        raise MomaError(f"--checkpoint NAME=RUN needs both, got {text!r}")
    return run, name


def add_parser(sub: argparse._SubParsersAction) -> None:
    ms = sub.add_parser("msr", help="manipulation success rate in closed loop", description=__doc__)
    ms.add_argument("--data", required=True, help="dataset directory (momakitchen generate)")
    ms.add_argument(
        "--checkpoint",
        action="append",
        default=[],
        metavar="RUN",
        help="run directory of a trained model, or NAME=RUN to report it as NAME "
        "(repeatable; with no --checkpoint, --predictions or --method: the bundled model)",
    )
    ms.add_argument(
        "--predictions",
        action="append",
        default=[],
        metavar="FILE",
        help="a method's maps of the split's episodes (.npz or .h5, docs/METHODS.md; repeatable)",
    )
    ms.add_argument(
        "--name",
        action="append",
        default=[],
        metavar="NAME",
        help="the name of each --predictions method, in order (default: the file's stem)",
    )
    ms.add_argument(
        "--method",
        action="append",
        default=[],
        metavar="METHOD",
        help=f"baseline: {', '.join(BASELINES)} (repeatable)",
    )
    ms.add_argument("--json", required=True, help="where to write the results (JSON)")
    ms.add_argument("--split", default="test", choices=SPLITS)
    ms.add_argument("--top-k", type=positive_int, default=5, help="points per method (5)")
    ms.add_argument(
        "--min-spread",
        type=float,
        default=0.2,
        help="minimum distance between the Top-k points (m, 0.2)",
    )
    ms.add_argument(
        "--pick-radius",
        type=non_negative_float,
        default=None,
        help="models and the oracle rank points by their map averaged over this radius "
        "(m; default 0: the raw map)",
    )
    ms.add_argument("--seed", type=non_negative_int, default=0)
    ms.add_argument(
        "--max-configs",
        type=non_negative_int,
        default=0,
        help="only the first N configurations (0: all)",
    )
    ms.add_argument("--quiet", action="store_true", help="no progress bar")
    add_robot_yaml(ms)
    ms.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from momakitchen.eval.msr import MsrConfig, format_msr_table, run_msr

    checkpoints = [_named_checkpoint(c) for c in args.checkpoint]
    args.checkpoint = [c[0] if isinstance(c, tuple) else c for c in checkpoints]
    predictions = checked_methods(args)
    out = output_file(args.json)  # an unwritable --json fails now, not after the trials
    radius = {} if args.pick_radius is None else {"pick_radius": args.pick_radius}
    config = MsrConfig(
        top_k=args.top_k,
        min_spread=args.min_spread,
        seed=args.seed,
        split=args.split,
        max_configs=args.max_configs,
        **radius,
    )
    t0 = time.perf_counter()
    result = run_msr(
        args.data,
        checkpoints,
        args.method,
        config,
        progress=not args.quiet,
        predictions=predictions,
    )
    result["seconds"] = round(time.perf_counter() - t0, 1)
    out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out, dumps_strict(result, indent=1) + "\n")
    print(format_msr_table(result))
    print(f"{result['seconds']:.0f} s -> {out}")
    return 0
