"""``momakitchen msr``: closed-loop manipulation success rate of models and baselines.

For every configuration of a split the world is rebuilt, each method picks base positions
on one first-person view (Top-1 and Top-k, spread apart), and the robot runs the
labelling's trial there in physics. Prints a table and writes the rates (overall, per
robot, per target category) and every trial's point and outcome as JSON. A
``--checkpoint`` given as NAME=RUN is reported as NAME.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from momakitchen.cli.common import checked_methods, output_file
from momakitchen.cli.options import (
    MSR_TOP_K,
    add_baselines,
    add_checkpoint,
    add_data,
    add_method_names,
    add_picking,
    add_quiet,
    add_results_json,
    add_robot_yaml,
    add_selection,
    config_fields,
)
from momakitchen.errors import MomaError
from momakitchen.fileio import atomic_write_text, dumps_strict


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
    add_data(ms)
    add_checkpoint(ms, repeatable=True)
    ms.add_argument(
        "--predictions",
        action="append",
        default=[],
        metavar="FILE",
        help="a method's maps of the split's episodes (.npz or .h5, docs/METHODS.md; repeatable)",
    )
    add_method_names(ms)
    add_baselines(ms)
    add_results_json(ms)
    add_selection(ms)
    add_picking(ms, MSR_TOP_K)
    add_quiet(ms)
    add_robot_yaml(ms)
    ms.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from momakitchen.eval.msr import MsrConfig, format_msr_table, run_msr

    checkpoints = [_named_checkpoint(c) for c in args.checkpoint]
    args.checkpoint = [c[0] if isinstance(c, tuple) else c for c in checkpoints]
    predictions = checked_methods(args)
    out = output_file(args.json)  # an unwritable --json fails now, not after the trials
    config = MsrConfig(**config_fields(args, MsrConfig))
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
