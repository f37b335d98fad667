"""A small distributed training run on synthetic episodes (checks the DDP path end to end).

Run it with two CPU processes::

    torchrun --nproc_per_node 2 -m momakitchen.train.ddp_smoke --out /tmp/ddp-run

Each process trains on its shard of the episodes (DistributedSampler, gloo backend);
rank 0 validates, writes the checkpoint and prints a one-line summary.
"""

from __future__ import annotations

import argparse
import os

import torch.distributed as dist

from momakitchen.data.synthetic import SyntheticConfig, SyntheticEpisodes
from momakitchen.fileio import dumps_strict
from momakitchen.models.config import TINY_MODEL
from momakitchen.train.config import TrainConfig
from momakitchen.train.trainer import train


def smoke_config(
    model: str, epochs: int, batch_size: int, checkpoint_minutes: float = 20.0
) -> TrainConfig:
    """A model small enough to train in seconds on one core per process."""
    return TrainConfig(
        model=model,
        preset="custom",
        model_config=TINY_MODEL,
        num_global=256,
        num_floor=128,
        epochs=epochs,
        batch_size=batch_size,
        progress=False,
        log_every=1,
        checkpoint_minutes=checkpoint_minutes,
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True, help="run directory")
    parser.add_argument("--model", default="navaff")
    parser.add_argument("--episodes", type=int, default=8)
    parser.add_argument("--epochs", type=int, default=2)
    parser.add_argument("--batch-size", type=int, default=2)
    parser.add_argument(
        "--checkpoint-minutes", type=float, default=20.0, help="checkpoints within an epoch"
    )
    args = parser.parse_args(argv)
    world = int(os.environ.get("WORLD_SIZE", "1"))
    if world > 1 and not dist.is_initialized():
        dist.init_process_group("gloo")
    rank = dist.get_rank() if dist.is_initialized() else 0
    data = SyntheticEpisodes(
        SyntheticConfig(num_episodes=args.episodes, num_global=256, num_floor=128, seed=1)
    )
    val = SyntheticEpisodes(SyntheticConfig(num_episodes=4, num_global=256, num_floor=128, seed=2))
    result = train(
        smoke_config(args.model, args.epochs, args.batch_size, args.checkpoint_minutes),
        data,
        val,
        args.out,
    )
    if rank == 0:
        last = result.history[-1]
        summary = {
            "world_size": dist.get_world_size() if dist.is_initialized() else 1,
            "epochs": len(result.history),
            "steps_per_process": result.global_step,
            "samples_per_epoch": last["samples"],
            "loss": round(last["loss"], 6),
            "val_loss": round(last["val_loss"], 6),
            "run_dir": str(result.run_dir),
        }
        print(dumps_strict(summary, null_non_finite=True))  # a diverged loss: null
    if dist.is_initialized():
        dist.destroy_process_group()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
