"""How often a model meets the held-out goal (share of the random -> oracle gap closed
>= 0.90 on every robot set) by chance of the configurations drawn, given its true share
(docs/RESULTS.md, "Robots the model never saw").

Each configuration: the oracle succeeds with probability ``--oracle``, random with
``--random`` (independently), the model with the probability that gives it the true
share, succeeding where the oracle fails with probability ``--beyond``. The estimated
share of a set is the one ``scripts/anyarm_report.py`` computes.

    python3 analyses/goal_power.py --configurations 60 300 --share 0.92 0.95 0.98
"""

from __future__ import annotations

import argparse

import numpy as np
from analysis_cli import run_main

from momakitchen.errors import MomaError


def pass_rates(
    share: float, n: int, sets: int, oracle: float, random: float, beyond: float, draws: int
) -> tuple[float, float]:
    """(P(every set meets the goal), P(one set meets it)) over ``draws`` simulated
    evaluations of ``sets`` sets of ``n`` configurations (seeded)."""
    rate = random + share * (oracle - random)
    where_oracle = (rate - (1 - oracle) * beyond) / oracle
    if not 0 <= where_oracle <= 1:
        raise MomaError(f"share {share} is not reachable with --beyond {beyond}")
    rng = np.random.default_rng(0)
    shape = (draws, sets, n)
    o = rng.random(shape) < oracle
    r = rng.random(shape) < random
    m = np.where(o, rng.random(shape) < where_oracle, rng.random(shape) < beyond)
    span = o.mean(-1) - r.mean(-1)
    closed = np.where(span > 0, (m.mean(-1) - r.mean(-1)) / np.where(span > 0, span, 1), 0.0)
    met = closed >= 0.90
    return float(met.all(-1).mean()), float(met.mean())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--configurations", type=int, nargs="+", default=[60, 300])
    ap.add_argument("--share", type=float, nargs="+", default=[0.92, 0.95, 0.98])
    ap.add_argument("--sets", type=int, default=5)
    ap.add_argument("--oracle", type=float, default=0.80)
    ap.add_argument("--random", type=float, default=0.15)
    ap.add_argument("--beyond", type=float, default=0.05)
    ap.add_argument("--draws", type=int, default=4000)
    args = ap.parse_args()
    if not 0 <= args.random < args.oracle <= 1:
        raise MomaError(f"want 0 <= --random < --oracle <= 1, got {args.random}, {args.oracle}")
    if args.sets < 1 or args.draws < 1 or min(args.configurations) < 1:
        raise MomaError("--sets, --draws and --configurations must be >= 1")
    print(f"| configurations a set | true share | P(all {args.sets} sets >= 0.90) | P(one set) |")
    print("| ---: | ---: | ---: | ---: |")
    for n in args.configurations:
        for share in args.share:
            every, one = pass_rates(
                share, n, args.sets, args.oracle, args.random, args.beyond, args.draws
            )
            print(f"| {n} | {share:.2f} | {every:.2f} | {one:.2f} |")


if __name__ == "__main__":
    run_main(main, "goal_power.py")
