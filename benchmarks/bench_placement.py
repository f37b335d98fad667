"""Timing of the classical base placement methods (docs/PLACEMENT.md): sampling a robot's
reachability map from cold (no cache on disk or in memory, the robot's own IK caches
dropped too), and one ``place`` call per method on stored frames once the map is cached.

Usage::

    python benchmarks/bench_placement.py [--robots panda ur5e xarm6] [--repeats 3]
        [--data DIR] [--calls 10]

Without ``--data``, a one-scene dataset (scene 3, 2 views) is generated in a temporary
folder. Prints, per robot, the median wall and CPU time of ``--repeats`` map builds, and
per method the median wall and CPU time of a ``place`` call over the frames.
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path


def _dataset(out: Path) -> Path:
    from momakitchen.data.config import GenerationConfig, ViewConfig
    from momakitchen.data.generator import GenerateRequest, generate_dataset
    from momakitchen.generation.producer import scene_records
    from momakitchen.scene.configuration import SceneConfig

    cfg = GenerationConfig(scene=SceneConfig(configs_per_scene=1), views=ViewConfig(episodes=2))
    generate_dataset(
        GenerateRequest(out=out, num_scenes=1, first_scene_id=3),
        scene_records,
        cfg,
        progress=False,
        write_card=False,
    )
    return out


def _build(robot: str) -> tuple[float, float]:
    """Wall and CPU seconds of one map build from cold."""
    from momakitchen.placement import ReachabilityMap
    from momakitchen.robots.robot import forget_caches
    from momakitchen.sim import reachability

    reachability._SAMPLED.clear()
    reachability._MAPS.clear()
    forget_caches(robot)
    with tempfile.TemporaryDirectory() as cache:
        os.environ["MOMAKITCHEN_CACHE"] = cache
        wall, cpu = time.perf_counter(), time.process_time()
        ReachabilityMap.for_robot(robot)
        return time.perf_counter() - wall, time.process_time() - cpu


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", nargs="+", default=["panda", "ur5e", "xarm6"])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--data", type=Path, default=None, help="a dataset (momakitchen generate)")
    ap.add_argument("--calls", type=int, default=10, help="place calls per method and frame")
    args = ap.parse_args(argv)
    saved = os.environ.get("MOMAKITCHEN_CACHE")
    print(f"load average at start: {os.getloadavg()[0]:.1f}")
    for robot in args.robots:
        runs = [_build(robot) for _ in range(args.repeats)]
        wall = statistics.median(r[0] for r in runs)
        cpu = statistics.median(r[1] for r in runs)
        print(f"map {robot}: median wall {wall:.1f} s, CPU {cpu:.1f} s over {len(runs)} builds")
    with tempfile.TemporaryDirectory() as tmp:
        os.environ["MOMAKITCHEN_CACHE"] = tmp
        data = args.data if args.data is not None else _dataset(Path(tmp) / "ds")
        _place_calls(data, args.calls)
    if saved is None:
        os.environ.pop("MOMAKITCHEN_CACHE", None)
    else:
        os.environ["MOMAKITCHEN_CACHE"] = saved
    print(f"load average at end: {os.getloadavg()[0]:.1f}")
    return 0


def _place_calls(data: Path, calls: int) -> None:
    from momakitchen.data.episode import SEMANTIC_CLASSES
    from momakitchen.data.shard import SceneShard
    from momakitchen.placement import CLASSICAL_METHODS, place

    target, obstacle = SEMANTIC_CLASSES.index("target"), SEMANTIC_CLASSES.index("obstacle")
    frames = []
    for shard_path in sorted((data / "scenes").glob("*.h5"))[:3]:
        with SceneShard(shard_path) as shard:
            for config in shard.config_indices():
                frames += [shard.episode(config, i) for i in shard.episode_indices(config)]
    for method in CLASSICAL_METHODS:
        times, cpu = [], []
        for ep in frames:
            inputs = dict(
                obstacle_masks=[ep.semantic == obstacle],
                mount_height=round(float(ep.descriptor[1]), 6),
            )
            args = (ep.depth, ep.intrinsics, ep.camera_to_base, ep.semantic == target, ep.robot)
            place(method, *args, **inputs)  # the map is built (and cached) here
            for _ in range(calls):
                t0, c0 = time.perf_counter(), time.process_time()
                place(method, *args, **inputs)
                times.append(time.perf_counter() - t0)
                cpu.append(time.process_time() - c0)
        print(
            f"place {method}: median wall {1000 * statistics.median(times):.0f} ms, CPU "
            f"{1000 * statistics.median(cpu):.0f} ms over {len(times)} calls on {len(frames)} "
            "frames"
        )


if __name__ == "__main__":
    raise SystemExit(main())
