"""Paired timing of ``momakitchen.predict`` with floor-plane inference against the path
before it (extrinsics trusted: ``analyses/robustness_before.py``), on the same stored
frames, alternating, in one process (so a busy machine slows both alike).

Usage::

    python benchmarks/bench_floor.py --data DIR [--frames 12] [--passes 2]

Prints the two medians (no MC dropout) and the median of the per-frame ratios.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "analyses"))

import momakitchen
from momakitchen.data import manifest as mf
from momakitchen.data.episode import episode_frame
from momakitchen.data.shard import SceneShard
from momakitchen.models.inference import predict_map
from momakitchen.robots.descriptor import robot_descriptor
from momakitchen.robots.spec import get_robot_spec
from momakitchen.train.checkpoint import default_checkpoint, load_checkpoint


def main(argv: list[str] | None = None) -> int:
    from robustness_before import trusting_frame_inputs

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True, help="dataset directory (momakitchen generate)")
    ap.add_argument("--frames", type=int, default=12)
    ap.add_argument("--passes", type=int, default=2)
    args = ap.parse_args(argv)
    root = Path(args.data)
    manifest = mf.load_manifest(root)
    run = load_checkpoint(default_checkpoint())
    episodes = []
    for entry in manifest["shards"].values():
        with SceneShard(root / entry["file"]) as shard:
            for c in shard.config_indices():
                episodes.append(shard.episode(c, shard.episode_indices(c)[-1]))
                if len(episodes) == args.frames:
                    break
        if len(episodes) == args.frames:
            break
    new, old = [], []
    for _ in range(args.passes):
        for ep in episodes:
            f = episode_frame(ep)
            t = time.perf_counter()
            momakitchen.predict(
                f.depth,
                ep.intrinsics,
                f.camera_to_base,
                f.target_mask,
                ep.robot,
                rgb=f.rgb,
                obstacle_masks=list(f.obstacle_masks),
                mc_samples=0,
                checkpoint=run,
            )
            new.append(time.perf_counter() - t)
            t = time.perf_counter()
            clouds = trusting_frame_inputs(
                f.depth,
                f.depth > 0,
                f.rgb,
                f.target_mask,
                f.obstacle_masks,
                f.intrinsics,
                f.camera_to_base,
                run.preprocessing.cloud,
                run.preprocessing.max_depth,
            )
            desc = np.asarray(robot_descriptor(get_robot_spec(ep.robot)), np.float32)
            predict_map(run, clouds, ep.robot, desc, mc_samples=0)
            old.append(time.perf_counter() - t)
    ratio = statistics.median(a / b for a, b in zip(new, old, strict=True))
    print(
        f"floor-plane predict {statistics.median(new) * 1000:.0f} ms, before "
        f"{statistics.median(old) * 1000:.0f} ms, ratio {ratio:.2f} "
        f"({len(new)} frames, load {os.getloadavg()[0]:.1f})"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
