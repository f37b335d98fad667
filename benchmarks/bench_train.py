"""Benchmark the training loop end to end: samples per second of ``train()`` on a dataset.

Usage::

    python benchmarks/bench_train.py --data DIR --model navaff --threads 1 --workers 0
    python benchmarks/bench_train.py --data DIR --threads 2 --workers 1 --runs 3 --steps 60
    python benchmarks/bench_train.py --data DIR --threads 1 --workers 1 --sensor-noise

Each run trains the ``cpu`` preset from scratch for ``--steps`` optimiser steps on the
train split of a generated dataset (HDF5 reading, collation, the model's geometry, forward,
backward and the optimiser, exactly as ``momakitchen train`` does) into a temporary run
directory, and reports the trainer's own samples per second over those steps (the data
loader's start-up included). The median over ``--runs`` is printed as one Markdown row.
The 1-minute load average before and after is recorded: other processes on the cores
lower the figure.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

from momakitchen.data.torch_dataset import EpisodeDataset
from momakitchen.train import preset_config, train


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True, help="dataset directory (momakitchen generate)")
    ap.add_argument("--model", default="navaff")
    ap.add_argument("--threads", type=int, default=1, help="torch threads (training process)")
    ap.add_argument("--workers", type=int, default=0, help="DataLoader worker processes")
    ap.add_argument("--steps", type=int, default=60, help="optimiser steps per run")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument(
        "--sensor-noise",
        action="store_true",
        help="every sample rebuilt through a random real sensor (train --sensor-noise)",
    )
    args = ap.parse_args(argv)
    data = EpisodeDataset(args.data, "train")
    config = preset_config("cpu", args.model).replace(
        num_threads=args.threads,
        num_workers=args.workers,
        max_steps=args.steps,
        epochs=1,
        progress=False,
        log_every=10_000,
        sensor_noise=args.sensor_noise,
    )
    rates = []
    load0 = os.getloadavg()[0]
    for _ in range(args.runs):
        with tempfile.TemporaryDirectory() as tmp:
            t = time.perf_counter()
            result = train(config, data, None, tmp)
            wall = time.perf_counter() - t
        rate = result.history[-1]["samples_per_s"]
        rates.append(rate)
        print(f"run: {rate:.2f} samples/s ({wall:.1f} s wall)", file=sys.stderr)
    load1 = os.getloadavg()[0]
    runs = " / ".join(f"{r:.2f}" for r in rates)
    print(
        f"| {args.model}{' (sensor noise)' if args.sensor_noise else ''} | {args.threads} "
        f"| {args.workers} | {config.batch_size} | {args.steps} "
        f"| {statistics.median(rates):.2f} | {runs} | {load0:.1f} / {load1:.1f} |"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
