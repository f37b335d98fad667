"""Labelling throughput: trials per second per core, seconds per configuration, and where
the time goes (checks, IK, physics), over a fixed set of configurations.

    python benchmarks/bench_labels.py --scenes 8 --configs 3 [--profile out/labels.prof]

Times are CPU seconds of this process (one core), which a busy machine disturbs less than
wall time; the wall-time total is printed too.
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import statistics
import time

from momakitchen.scene.configuration import sample_scene
from momakitchen.sim.labels import label_configuration
from momakitchen.sim.world import World


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=8)
    ap.add_argument("--configs", type=int, default=3)
    ap.add_argument("--profile", default=None, help="write a cProfile of the whole run here")
    args = ap.parse_args()
    prof = cProfile.Profile() if args.profile else None
    rows = []
    wall0 = time.perf_counter()
    for sid in range(args.scenes):
        scene = sample_scene(sid)
        with World(scene.layout) as world:
            for cfg in scene.configurations[: args.configs]:
                t0 = time.process_time()
                if prof:
                    prof.enable()
                labels = label_configuration(world, cfg)
                if prof:
                    prof.disable()
                cpu = time.process_time() - t0
                s = labels.summary()
                rows.append(
                    (
                        sid,
                        cfg.index,
                        cfg.robot,
                        labels.target,
                        s["positions"],
                        s["physics_trials"],
                        s["successes"],
                        cpu,
                        labels.seconds,
                    )
                )
    wall = time.perf_counter() - wall0
    print("| scene | config | robot | target | trials | in physics | successes | CPU s |")
    print("| ---: | ---: | --- | --- | ---: | ---: | ---: | ---: |")
    for sid, k, robot, target, n, phys, ok, cpu, _ in rows:
        print(f"| {sid} | {k} | {robot} | {target} | {n} | {phys} | {ok} | {cpu:.2f} |")
    cpus = [r[7] for r in rows]
    trials = sum(r[4] for r in rows)
    physics = sum(r[5] for r in rows)
    split = {k: sum(r[8][k] for r in rows) for k in ("check", "ik", "physics", "total")}
    print(f"\nconfigurations: {len(rows)}, trials: {trials} ({physics} executed in physics)")
    print(
        f"CPU seconds per configuration: median {statistics.median(cpus):.2f}, "
        f"mean {statistics.mean(cpus):.2f}, max {max(cpus):.2f}"
    )
    print(
        f"trials per CPU second: {trials / sum(cpus):.1f}; physics trials per CPU second: "
        f"{physics / sum(cpus):.1f}"
    )
    print(
        "wall-time split: "
        + ", ".join(
            f"{k} {100 * v / split['total']:.0f} %" for k, v in split.items() if k != "total"
        )
    )
    print(f"wall time of the run: {wall:.1f} s")
    if prof:
        prof.dump_stats(args.profile)
        pstats.Stats(prof).sort_stats("tottime").print_stats(12)


if __name__ == "__main__":
    main()
