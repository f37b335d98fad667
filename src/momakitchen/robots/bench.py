"""Measurements of the robot models: workspace radius and IK round trips.

Run ``python -m momakitchen.robots.bench [--poses N] [--runs R]``; it prints Markdown
tables (the ones in ``docs/ROBOTS.md`` and ``docs/bench/robots.md``).

IK round trip: a random joint vector within the limits gives a reachable TCP pose (FK);
IK is solved for that pose starting from the home configuration (as labelling does), and
FK of the answer must be within 5 mm and 2 degrees of the pose.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import statistics
import time
from dataclasses import dataclass

import numpy as np

from momakitchen.bullet import p
from momakitchen.robots.reach import measure_workspace
from momakitchen.robots.robot import Robot
from momakitchen.robots.spec import DEFAULT_ROBOTS, ROBOTS


@dataclass(frozen=True)
class IKStats:
    """IK round-trip figures of one robot over ``n`` poses."""

    name: str
    n: int
    success_rate: float
    median_ms: float
    p90_ms: float
    median_cpu_ms: float
    median_position_mm: float
    median_orientation_deg: float
    max_success_position_mm: float
    max_success_orientation_deg: float


def ik_round_trip(robot: Robot, n: int = 200, seed: int = 0) -> IKStats:
    """FK -> IK -> FK on ``n`` random reachable poses (IK seeded at home)."""
    rng = np.random.default_rng(seed)
    times, cpu, perr, oerr, ok = [], [], [], [], []
    for _ in range(n):
        q = rng.uniform(robot.lower, robot.upper)
        pos, orn = robot.tcp_pose(q)
        c0 = time.process_time()
        res = robot.solve_ik(pos, orn, seed=robot.home, rng=rng)
        cpu.append((time.process_time() - c0) * 1e3)
        # Independent check of the answer by FK.
        got_pos, got_orn = robot.tcp_pose(res.q)
        e_pos = float(np.linalg.norm(got_pos - pos))
        e_ori = 2 * math.acos(min(1.0, abs(float(np.dot(got_orn, orn)))))
        success = res.success and e_pos <= 0.005 and e_ori <= math.radians(2)
        times.append(res.seconds * 1e3)
        perr.append(e_pos * 1e3)
        oerr.append(math.degrees(e_ori))
        ok.append(success)
    good_p = [e for e, s in zip(perr, ok, strict=True) if s] or [float("nan")]
    good_o = [e for e, s in zip(oerr, ok, strict=True) if s] or [float("nan")]
    return IKStats(
        robot.name,
        n,
        float(np.mean(ok)),
        float(np.median(times)),
        float(np.percentile(times, 90)),
        float(np.median(cpu)),
        float(np.median(perr)),
        float(np.median(oerr)),
        max(good_p),
        max(good_o),
    )


def label_sweep(robot: Robot, grid: float = 0.1) -> tuple[int, int, float, float]:
    """A labelling-like workload: one target, the base on a grid in the semicircle of
    radius ``reach`` in front of it, facing it; IK to a top-down grasp at each point.

    The target sits 0.1 m below the mount height, 0.15 m above a counter edge at the
    origin. Returns ``(grid points, IK successes, seconds)``.
    """
    reach = ROBOTS[robot.name].reach
    target = np.array([0.0, 0.0, ROBOTS[robot.name].mount_height - 0.1])
    ticks = np.arange(-reach, reach + 1e-9, grid)
    points = [
        (x, y) for x in ticks for y in ticks if x < -0.3 and math.hypot(x, y) <= reach
    ]  # in front of the counter
    t0 = time.perf_counter()
    c0 = time.process_time()
    ok = 0
    for x, y in points:
        robot.place_base(x, y, math.atan2(-y, -x))
        res = robot.solve_ik(target, (1.0, 0.0, 0.0, 0.0), seed=robot.home)
        ok += res.success
    return len(points), ok, time.perf_counter() - t0, time.process_time() - c0


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=200, help="IK poses per robot and run")
    parser.add_argument("--runs", type=int, default=3, help="runs (medians are reported)")
    parser.add_argument(
        "--robots", nargs="*", default=list(DEFAULT_ROBOTS), help="default: the paper's six"
    )
    args = parser.parse_args(argv)
    client = p.connect(p.DIRECT)
    print(
        f"machine: {platform.machine()}, {os.cpu_count()} CPUs, Python {platform.python_version()}"
    )
    print(
        "\n| robot | manufacturer reach (m) | measured flange reach (m) | ratio | TCP reach (m) |"
    )
    print("| --- | --- | --- | --- | --- |")
    robots = {}
    for name in args.robots:
        robot = Robot(client, name)
        robots[name] = robot
        flange, tcp = measure_workspace(robot, 4000)
        reach = ROBOTS[name].reach
        print(f"| {name} | {reach:.3f} | {flange:.3f} | {flange / reach:.3f} | {tcp:.3f} |")
    print(f"\nIK round trip: {args.poses} random poses per run, {args.runs} runs, medians")
    print(
        "\n| robot | success rate | median solve (ms) | p90 solve (ms) | median CPU (ms) "
        "| median pos. err (mm) | median ori. err (deg) |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for name, robot in robots.items():
        runs = [ik_round_trip(robot, args.poses, seed=run) for run in range(args.runs)]

        def med(attr: str, runs=runs) -> float:
            return statistics.median(getattr(r, attr) for r in runs)

        print(
            f"| {name} | {med('success_rate'):.3f} | {med('median_ms'):.2f} | "
            f"{med('p90_ms'):.2f} | {med('median_cpu_ms'):.2f} | "
            f"{med('median_position_mm'):.3f} | "
            f"{med('median_orientation_deg'):.3f} |"
        )
    print(
        "\nLabelling-like sweep: base on a 10 cm grid within reach of one target, facing "
        "it; top-down IK from home at each point (median of runs)"
    )
    print(
        "\n| robot | grid points | IK successes | seconds per sweep | CPU seconds | "
        "ms per point (wall) |"
    )
    print("| --- | --- | --- | --- | --- | --- |")
    for name, robot in robots.items():
        sweeps = [label_sweep(robot) for _ in range(args.runs)]
        n, ok = sweeps[0][0], sweeps[0][1]
        sec = statistics.median(s[2] for s in sweeps)
        cpu = statistics.median(s[3] for s in sweeps)
        print(f"| {name} | {n} | {ok} | {sec:.2f} | {cpu:.2f} | {1e3 * sec / max(n, 1):.2f} |")
    p.disconnect(client)


if __name__ == "__main__":
    main()
