"""Where a method's closed-loop misses stand against the arm's reach: each Top-1 pick of a
`momakitchen msr` result (or a `robot-check`'s check.json) placed against the labelling's
successful trials of its configuration and against the arm's reachability map.

    MOMAKITCHEN_ROBOT_YAML=pub/panda13.yaml python analyses/reach_band.py \
        --data check-panda13/data --msr check-panda13/check.json

Over the feasible configurations (some labelling trial succeeded), per method and outcome
(success, or the stage that failed): how many; the pick's distance from the target's anchor;
how far beyond the farthest successful labelling trial of its configuration it stands
(``beyond``, m: > 0 is farther from the target than any stance that worked); and ``d``, how
far inside the arm's reachable region the anchor lies from the pick (the better of a
horizontal and a top-down approach, :mod:`momakitchen.sim.reachability`, the quantity the
models' reach gate reads; m, < 0 outside). A last block gives ``d`` over every labelling
trial, by stage: how sharply the map parts the stances that worked from those out of reach.
"""

from __future__ import annotations

import argparse
from collections import defaultdict
from pathlib import Path

import numpy as np
from analysis_cli import run_main

from momakitchen.data.manifest import load_manifest
from momakitchen.data.shard import SceneShard
from momakitchen.errors import MomaError
from momakitchen.fileio import read_json_object
from momakitchen.sim.config import STAGE_NAMES
from momakitchen.sim.reachability import ReachabilityMap

_DOWN = np.array([0.0, 0.0, -1.0])
BASELINES = ("random", "nearest")  # not maps: their picks say nothing of a model's reach


def inside(rmap: ReachabilityMap, base_xy: np.ndarray, anchor: np.ndarray) -> np.ndarray:
    """``d`` (m) of the anchor from bases at ``base_xy`` (N, 2) facing it -> (N,)."""
    side = rmap.signed_distance(*rmap.tcp_coordinates(base_xy, anchor, None))
    down = rmap.signed_distance(*rmap.tcp_coordinates(base_xy, anchor, _DOWN))
    return np.maximum(side, down)


def band_rows(data: Path, result: dict, methods: list[str] | None) -> tuple[dict, dict]:
    """(per method, per outcome: lists of (distance, beyond, d)); per stage: the labelling
    trials' ``d`` values. The outcome is ``"success"`` or the failed stage's name."""
    shards = {sid: data / e["file"] for sid, e in load_manifest(data)["shards"].items()}
    picks: dict[str, dict[str, list[tuple[float, float, float]]]] = defaultdict(
        lambda: defaultdict(list)
    )
    trials: dict[str, list[float]] = defaultdict(list)
    open_shards: dict[str, SceneShard] = {}
    try:
        for rec in result.get("records", []):
            if not rec.get("feasible"):
                continue
            sid = str(rec["scene_id"])
            if sid not in shards:
                raise MomaError(f"--msr scene {sid} is not in --data {str(data)!r}")
            if sid not in open_shards:
                open_shards[sid] = SceneShard(shards[sid])
            labels = open_shards[sid].configuration(int(rec["config_index"]))
            anchor = np.asarray(labels.anchor, np.float64)
            rmap = ReachabilityMap.for_robot(labels.robot, labels.mount_height)
            stages = np.asarray(labels.trial_stages)
            d_trials = inside(rmap, np.asarray(labels.trial_positions, np.float64), anchor)
            for st in np.unique(stages):
                trials[STAGE_NAMES[int(st)]].extend(d_trials[stages == st].tolist())
            ok = np.asarray(labels.trial_positions, np.float64)[stages == 0]
            farthest = float(np.max(np.hypot(*(ok - anchor[:2]).T)))
            for name, m in rec["methods"].items():
                if name in BASELINES or (methods and name not in methods) or not m["points"]:
                    continue
                pt = np.asarray(m["points"][0], np.float64)
                dist = float(np.hypot(*(pt - anchor[:2])))
                d = float(inside(rmap, pt[None], anchor)[0])
                outcome = STAGE_NAMES[int(m["stages"][0])]
                picks[name][outcome].append((dist, dist - farthest, d))
    finally:
        for shard in open_shards.values():
            shard.close()
    if not picks:
        raise MomaError("--msr has no feasible configuration with a map method's pick")
    return picks, trials


def format_band(picks: dict, trials: dict) -> str:
    q = lambda v: "/".join(f"{x:+.2f}" for x in np.percentile(v, [10, 50, 90]))  # noqa: E731
    lines = [
        "method | outcome | picks | distance m (q10/50/90) | beyond the farthest success m | d m",
        "--- | --- | ---: | --- | --- | ---",
    ]
    for name, outcomes in picks.items():
        order = ["success", *(s for s in STAGE_NAMES[1:] if s in outcomes)]
        for outcome in order:
            rows = np.asarray(outcomes.get(outcome, []))
            if len(rows):
                lines.append(
                    f"{name} | {outcome} | {len(rows)} | {q(rows[:, 0])} | {q(rows[:, 1])} "
                    f"| {q(rows[:, 2])}"
                )
    lines += ["", "labelling trials, stage | trials | d m (q10/50/90) | share d > 0"]
    lines.append("--- | ---: | --- | ---:")
    for stage in ["success", *STAGE_NAMES[1:]]:
        v = np.asarray(trials.get(stage, []))
        if len(v):
            lines.append(f"{stage} | {len(v)} | {q(v)} | {np.mean(v > 0):.2f}")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, required=True, help="the result's dataset")
    ap.add_argument("--msr", type=Path, required=True, help="msr JSON or robot-check check.json")
    ap.add_argument("--method", nargs="*", help="only these methods (default: every map)")
    args = ap.parse_args()
    picks, trials = band_rows(args.data, read_json_object(args.msr), args.method)
    print(format_band(picks, trials))


if __name__ == "__main__":
    run_main(main, "reach_band.py")
