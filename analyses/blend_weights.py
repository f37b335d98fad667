"""A fine-tuned run's weights moved back toward the weights it was fine-tuned from.

    python analyses/blend_weights.py src/momakitchen/checkpoints/body 0.5 body-blend05

Writes DST, a copy of RUN (its ``config.json``: the same inputs and gates) whose weights
are ``start + ALPHA * (RUN - start)``, ``start`` the weights RUN's training began from (its
``init``, e.g. ``bundled``), widened to RUN's inputs as the fine-tune widened them (zero
columns for the descriptor's new numbers and the reachability channels). ALPHA 1 is RUN,
ALPHA 0 the start read through RUN's inputs. Interpolating fine-tuned weights toward their
start is a known way to keep what the start knew (weight-space ensembling, WiSE-FT:
Wortsman et al., "Robust fine-tuning of zero-shot models", CVPR 2022); docs/RESULTS.md
asks whether it keeps the bundled model's six arms for `body`.
"""

from __future__ import annotations

import argparse
import shutil
from pathlib import Path

import torch
from analysis_cli import run_main

from momakitchen.errors import MomaError
from momakitchen.models.registry import build_model
from momakitchen.train.checkpoint import (
    WEIGHTS_FILE,
    load_weights,
    read_run_config,
    resolve_run_dir,
    save_weights,
)


def blend(run: Path, alpha: float, dst: Path) -> None:
    """Write ``dst`` (module docstring); MomaError on bad input, before anything is
    written."""
    if not 0.0 <= alpha <= 1.0:
        raise MomaError(f"ALPHA must be in [0, 1], got {alpha}")
    if dst.exists():
        raise MomaError(f"{str(dst)!r} exists; give a new directory")
    config, _ = read_run_config(run)
    if not config.init:
        raise MomaError(f"run {str(run)!r} was not fine-tuned (its config has no init)")
    start_dir = resolve_run_dir(config.init)
    start, _ = read_run_config(start_dir)
    net = build_model(config.model, config.model_config)
    load_weights(
        start_dir / WEIGHTS_FILE,
        net,
        descriptor_from=start.model_config.descriptor_dim,
        reach_from_none=config.model_config.reach_input and not start.model_config.reach_input,
    )
    began = {k: v.clone() for k, v in net.state_dict().items()}
    load_weights(run / WEIGHTS_FILE, net)
    ended = net.state_dict()
    # torch.lerp returns ``ended`` exactly at 1; counters (integers) are the run's.
    net.load_state_dict(
        {
            k: torch.lerp(began[k], v, alpha) if v.is_floating_point() else v
            for k, v in ended.items()
        }
    )
    tmp = dst.with_name(dst.name + ".partial")
    shutil.rmtree(tmp, ignore_errors=True)
    shutil.copytree(run, tmp)
    save_weights(tmp / WEIGHTS_FILE, net)
    tmp.rename(dst)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run", type=Path, help="a fine-tuned run directory (its config has init)")
    ap.add_argument("alpha", type=float, help="how far from the start toward RUN, in [0, 1]")
    ap.add_argument("dst", type=Path, help="new run directory")
    args = ap.parse_args()
    blend(resolve_run_dir(args.run), args.alpha, args.dst)
    print(f"wrote {args.dst}: {args.run} at {args.alpha} of the way from its start")


if __name__ == "__main__":
    run_main(main, "blend_weights.py")
