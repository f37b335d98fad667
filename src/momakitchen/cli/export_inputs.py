"""``momakitchen export-inputs``: a split's model inputs in a plain file, for methods that
run outside momakitchen.

Writes, for every episode of the split that has floor points, its first-person cloud with
the target / obstacle channel, the floor points to score (in the order a predictions file
must follow), the robot descriptor and name, and the camera (intrinsics, camera-to-base
transform), under the key ``scene/config/episode`` of an ``.npz`` or ``.h5`` file that
NumPy or h5py read alone. Score the floor points, write a predictions file and pass it to
``evaluate``, ``msr`` or ``benchmark`` with ``--predictions`` (docs/METHODS.md).

With ``--robustness``, writes instead the robustness track's inputs: the view ``msr``
picks for each configuration (``--seed``), under each corruption (``--corruption``,
default every one; ``clean`` always), as the real-robot path gives it to a model (the
corrupted cloud after the floor-plane correction), keyed ``corruption/scene/config/
episode``. Score them and pass the file to ``robustness --predictions``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from momakitchen.cli.common import output_file
from momakitchen.cli.options import (
    add_data,
    add_max_configs,
    add_quiet,
    add_robot_yaml,
    add_seed,
    add_split,
    config_fields,
)
from momakitchen.errors import MomaError
from momakitchen.fileio import existing_dir


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "export-inputs",
        help="a split's model inputs as a plain .npz / .h5 (methods run elsewhere)",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_data(p)
    add_split(p)
    p.add_argument("--out", required=True, help="the inputs file to write (.npz, .h5 or .hdf5)")
    p.add_argument(
        "--images", action="store_true", help="also each view's rgb and depth images (large)"
    )
    rob = p.add_argument_group("robustness track (robustness --predictions)")
    rob.add_argument(
        "--robustness",
        action="store_true",
        help="the views robustness judges, under each corruption, as the robot path gives them",
    )
    rob.add_argument(
        "--corruption",
        action="append",
        default=[],
        metavar="NAME",
        help="a corruption (repeatable; default: every one; 'clean' is always added first)",
    )
    add_seed(rob)
    add_max_configs(rob)
    add_quiet(rob)
    add_robot_yaml(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from momakitchen.eval.predictions import export_inputs, file_kind

    root = existing_dir(args.data, "dataset directory")
    out = output_file(args.out)
    file_kind(out)  # a wrong suffix fails before any reading
    t0 = time.perf_counter()
    if args.robustness:
        return _robustness(args, root, out, t0)
    if args.corruption or args.seed or args.max_configs:
        raise MomaError("--corruption, --seed and --max-configs need --robustness")
    n = export_inputs(root, args.split, out, images=args.images)
    print(f"{n} {args.split} episodes in {time.perf_counter() - t0:.1f} s -> {out}")
    return 0


def _robustness(args: argparse.Namespace, root: Path, out: Path, t0: float) -> int:
    from momakitchen.eval.robustness.export import export_robustness_inputs
    from momakitchen.eval.robustness.views import RobustnessConfig
    from momakitchen.perception.sensors import CORRUPTIONS

    names = list(args.corruption) or list(CORRUPTIONS)
    config = RobustnessConfig(
        corruptions=("clean", *[n for n in names if n != "clean"]),
        **config_fields(args, RobustnessConfig),
    )
    counts = export_robustness_inputs(
        root, out, config, images=args.images, progress=not args.quiet
    )
    views = ", ".join(f"{v} {k}" for k, v in sorted(counts.items()))
    print(
        f"{sum(counts.values())} views x corruptions of {args.split} ({views}) in "
        f"{time.perf_counter() - t0:.1f} s -> {out}"
    )
    return 0
