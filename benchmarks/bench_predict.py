"""Benchmark ``momakitchen.predict`` on dataset episodes: latency per frame on this machine.

Usage::

    python benchmarks/bench_predict.py --data DIR [--checkpoint RUN] [--episodes 20]

Each episode's raw inputs (640x480 depth, RGB, target and obstacle masks, intrinsics,
extrinsics) go through the whole real-robot path: back-projection, clouds, the model, the
Top-5 poses. Reported: median and 90th percentile wall milliseconds without uncertainty
(``mc_samples=0``) and with the default 8 MC-dropout passes, after two warm-up calls, plus
the 1-minute load average (other processes inflate timings). ``--threads`` is passed to
``predict`` (its default, 1, is the fastest for single frames).
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

import numpy as np

import momakitchen
from momakitchen.data.episode import SEMANTIC_CLASSES
from momakitchen.data.manifest import load_manifest
from momakitchen.data.shard import SceneShard
from momakitchen.train.checkpoint import default_checkpoint, load_checkpoint

TARGET, OBSTACLE = SEMANTIC_CLASSES.index("target"), SEMANTIC_CLASSES.index("obstacle")


def predict_episode(ep, run, mc: int, depth: np.ndarray | None = None, threads: int = 1):
    """``momakitchen.predict`` on a stored episode's raw frame (its own depth unless
    ``depth`` is given), as a robot would call it."""
    return momakitchen.predict(
        ep.depth if depth is None else depth,
        ep.intrinsics,
        ep.camera_to_base,
        ep.semantic == TARGET,
        ep.robot,
        rgb=ep.rgb,
        obstacle_masks=[ep.semantic == OBSTACLE],
        checkpoint=run,
        mc_samples=mc,
        threads=threads,
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--checkpoint", default=None)
    ap.add_argument("--episodes", type=int, default=20)
    ap.add_argument("--threads", type=int, default=1)
    args = ap.parse_args()
    run = load_checkpoint(args.checkpoint or default_checkpoint())
    manifest = load_manifest(args.data)
    episodes = []
    for entry in manifest["shards"].values():
        if entry["split"] != "test":
            continue
        with SceneShard(os.path.join(args.data, entry["file"])) as shard:
            episodes.append(shard.episode(0, shard.episode_indices(0)[-1]))
        if len(episodes) == args.episodes:
            break

    def call(ep, mc):
        return predict_episode(ep, run, mc, threads=args.threads)

    print(
        f"{len(episodes)} test episodes, model {run.config.model} ({run.config.preset}), "
        f"{args.threads} torch threads, {os.cpu_count()} CPUs, load {os.getloadavg()[0]:.2f}"
    )
    for mc in (0, 8):
        call(episodes[0], mc)
        call(episodes[0], mc)
        ms = []
        for ep in episodes:
            t = time.perf_counter()
            call(ep, mc)
            ms.append(1000 * (time.perf_counter() - t))
        print(
            f"mc_samples={mc}: median {statistics.median(ms):.0f} ms, p90 "
            f"{np.percentile(ms, 90):.0f} ms (load {os.getloadavg()[0]:.2f})"
        )


if __name__ == "__main__":
    main()
