"""Copy a trained run with the robot's body gates set (ModelConfig.reach_gate,
index_gate and footprint_gate).

    python scripts/gate_checkpoint.py SRC DST [--width 0.03] [--points 8] [--index R [--picks-only]]
        [--footprint]

``SRC`` is a run directory (``momakitchen train``) or ``bundled``; ``DST`` a new directory.
The gates have no weights: the copy predicts what ``SRC`` does, multiplied at each floor
point by ``sigmoid(d / width)``, ``d`` how far inside the arm's reachable region the target
lies from there, at ``points`` of its points (docs/ROBOTS.md, "What the model knows of a
robot"); with ``--index R`` also by ``min(1, r / R)``, ``r`` the reachability index of the
target from there (the share of approach directions by which the arm reaches it), and with
``--picks-only`` for targets the robot picks only, not those it opens; with
``--footprint`` also by 0 where the robot's base, facing the target, would stand on what the
view shows above the floor (``--width 0``: no sigmoid). Every command that takes
``--checkpoint`` takes the copy; its robots must be registered (a name or ``--robot-yaml``):
the gates read the arm's URDF and the base's footprint.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
from pathlib import Path

from momakitchen.errors import MomaError
from momakitchen.fileio import atomic_write_text
from momakitchen.models import ModelConfig
from momakitchen.train.checkpoint import CONFIG_FILE, default_checkpoint, read_run_config


def gate_copy(
    src: Path,
    dst: Path,
    width: float,
    points: int,
    footprint: bool = False,
    index: float = 0.0,
    picks_only: bool = False,
) -> None:
    """Copy run ``src`` to the new directory ``dst`` with the gate set (MomaError on bad
    input, before anything is written)."""
    read_run_config(src)  # a run directory
    if dst.exists():
        raise MomaError(f"{str(dst)!r} exists; give a new directory")
    info = json.loads((src / CONFIG_FILE).read_text())
    model_config = info["train_config"]["model_config"]
    model_config.update(reach_gate=width, reach_points=points, footprint_gate=footprint)
    # a copy of a copy keeps none of its weight
    model_config.pop("index_gate", None)
    model_config.pop("index_picks_only", None)
    if index:
        model_config["index_gate"] = index
    if picks_only:
        model_config["index_picks_only"] = True
    ModelConfig.from_dict(model_config)  # the gate's values are checked here
    tmp = dst.with_name(dst.name + ".partial")
    shutil.rmtree(tmp, ignore_errors=True)
    shutil.copytree(src, tmp)
    atomic_write_text(tmp / CONFIG_FILE, json.dumps(info, indent=2) + "\n")
    tmp.rename(dst)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("src", help="run directory, or 'bundled'")
    parser.add_argument("dst", help="new run directory")
    parser.add_argument("--width", type=float, default=0.03, help="gate width in m (0.03)")
    parser.add_argument("--points", type=int, default=8, help="target points read (8)")
    parser.add_argument(
        "--index",
        type=float,
        default=0.0,
        help="also weigh by min(1, the arm's reachability index / INDEX) (0: not)",
    )
    parser.add_argument(
        "--picks-only",
        action="store_true",
        help="with --index: weigh the targets the robot picks only, not those it opens",
    )
    parser.add_argument(
        "--footprint", action="store_true", help="also gate where the base does not fit"
    )
    args = parser.parse_args(argv)
    src = default_checkpoint() if args.src == "bundled" else Path(args.src)
    try:
        gate_copy(
            src,
            Path(args.dst),
            args.width,
            args.points,
            args.footprint,
            args.index,
            args.picks_only,
        )
    except MomaError as exc:
        print(f"gate_checkpoint: error: {exc}", file=sys.stderr)
        return 2
    gates = [f"reach_gate {args.width} m at {args.points} points"]
    gates += [f"index_gate {args.index}"] if args.index else []
    gates += ["for picks only"] if args.picks_only else []
    gates += ["footprint_gate"] if args.footprint else []
    print(f"wrote {args.dst}: {args.src} with {' and '.join(gates)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
