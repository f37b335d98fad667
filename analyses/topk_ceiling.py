"""How high can Top-k MSR go on these labels? For each test configuration, the most
successful grid trials that lie at least the MSR's spread apart (up to k): a chooser that
knew every grid trial's outcome could do no better than pick those, so their mean share of
k bounds Top-k MSR from the grid's side, next to the Top-1 bound (the feasible share).

The largest spread set is found by greedy packing over random orders of each
configuration's successful positions (best of ``--tries``), which is exact when it reaches
k and a lower bound of the largest set otherwise.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
from analysis_cli import run_main

from momakitchen.data.shard import SceneShard
from momakitchen.errors import MomaError


def spread_set_size(points: np.ndarray, spread: float, k: int, tries: int, seed: int) -> int:
    """Size (up to ``k``) of the largest set of ``points`` (N, 2) pairwise at least
    ``spread`` apart that greedy packing over ``tries`` random orders finds."""
    rng = np.random.default_rng(seed)
    best = 0
    for _ in range(tries):
        chosen: list[np.ndarray] = []
        for p in points[rng.permutation(len(points))]:
            if all(np.hypot(*(p - q)) >= spread - 1e-9 for q in chosen):
                chosen.append(p)
                if len(chosen) == k:
                    return k
        best = max(best, len(chosen))
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, required=True)
    ap.add_argument("--top-k", type=int, default=5)
    ap.add_argument("--spread", type=float, default=0.2, help="metres (msr's min_spread)")
    ap.add_argument("--tries", type=int, default=300)
    args = ap.parse_args()
    if args.top_k < 1 or args.spread < 0 or args.tries < 1:
        raise MomaError(
            f"need --top-k >= 1, --spread >= 0, --tries >= 1; got {args.top_k}, "
            f"{args.spread}, {args.tries}"
        )
    manifest_path = args.data / "manifest.json"
    if not manifest_path.is_file():
        raise MomaError(f"no dataset at {args.data} (no manifest.json)")
    shards = json.loads(manifest_path.read_text())["shards"]
    sizes = []
    for sid in sorted(shards, key=int):
        if shards[sid]["split"] != "test":
            continue
        with SceneShard(args.data / shards[sid]["file"]) as shard:
            for c in range(shard.num_configurations):
                grid = shard.configuration(c)
                ok = grid.trial_positions[grid.trial_outcomes > 0]
                sizes.append(spread_set_size(ok, args.spread, args.top_k, args.tries, c))
    s = np.array(sizes)
    hist = ", ".join(f"{n}: {int((s == n).sum())}" for n in range(args.top_k + 1))
    print(f"{len(s)} test configurations; successful grid trials {args.spread} m apart ({hist})")
    top1, topk = np.mean(s > 0), np.mean(s / args.top_k)
    print(f"Top-1 ceiling {top1:.3f}, Top-{args.top_k} ceiling {topk:.3f}")


if __name__ == "__main__":
    run_main(main, "topk_ceiling.py")
