"""What the analyses in this folder share: the test views they score and their bad-input
exit (one line, status 2, as the ``momakitchen`` CLI does and ``scripts/script_cli.py``
repeats for the scripts)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path

import torch
from torch.utils.data import Subset

from momakitchen.data import EpisodeDataset
from momakitchen.errors import MomaError


def add_view_args(ap: argparse.ArgumentParser, every: int) -> None:
    """``--data``, ``--checkpoint RUN ...`` and ``--every N`` (every N-th test view)."""
    ap.add_argument("--data", type=Path, required=True)
    ap.add_argument("--checkpoint", type=Path, nargs="+", required=True)
    ap.add_argument("--every", type=int, default=every, help="score every N-th test view")


def test_views(args: argparse.Namespace) -> Subset:
    """Every ``args.every``-th view of the test split of ``args.data``, scored on one thread."""
    if args.every < 1:
        raise MomaError(f"--every must be >= 1, got {args.every}")
    torch.set_num_threads(1)
    data = EpisodeDataset(args.data, "test")
    return Subset(data, range(0, len(data), args.every))


def run_main(main: Callable[[], None], prog: str) -> None:
    """Call ``main`` with the user robots of ``$MOMAKITCHEN_ROBOT_YAML`` registered; bad
    input (a MomaError) becomes one line on stderr and exit status 2."""
    from momakitchen.robots.user import load_env_robots

    try:
        load_env_robots()
        main()
    except MomaError as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        sys.exit(2)
