"""Benchmark the approach track: CPU seconds of this process per episode.

Usage::

    python benchmarks/bench_approach.py --data DIR [--configs 10] [--repeats 3]

Runs the bundled model's ``single`` policy from far starts (one look: render, perception
preset, ``momakitchen.predict`` with 8 MC-dropout passes; planning; driving checked in
PyBullet; the trial) on the first ``--configs`` test configurations, ``--repeats`` times,
and reports per run the median and mean CPU seconds per episode (``time.process_time``
around each episode, as the records' ``cpu_seconds``), the configuration set-up (world,
trial runner, free space, far start) per configuration, and the 1-minute load average.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

from momakitchen.eval.approach.config import ApproachConfig
from momakitchen.eval.approach.track import run_approach


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--data", required=True)
    ap.add_argument("--configs", type=int, default=10)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    cfg = ApproachConfig(starts=("far",), policies=("single",), max_configs=args.configs)
    for k in range(args.repeats):
        t0 = time.process_time()
        result = run_approach(args.data, ["bundled"], config=cfg)
        total = time.process_time() - t0
        cpu = [r["cpu_seconds"] for r in result["records"]]
        setup = (total - sum(cpu)) / max(1, result["configurations"])
        print(
            f"run {k + 1}: {len(cpu)} episodes, CPU s per episode median "
            f"{statistics.median(cpu):.2f}, mean {statistics.mean(cpu):.2f}, max {max(cpu):.2f}; "
            f"set-up per configuration {setup:.2f} s; load {os.getloadavg()[0]:.1f}"
        )


if __name__ == "__main__":
    main()
