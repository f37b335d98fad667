"""How many of the stances that worked in the labelling the driven track's planner can
stand on: per robot, the labelling's successful trial positions where the base does not
fit by the floor plan.

    MOMAKITCHEN_ROBOT_YAML=pub/panda13.yaml python analyses/planner_stances.py \
        --data ho30/panda_public13

The labelling places the base in PyBullet and checks its collision shape against the
furniture's; the approach track plans on free cells by
:func:`~momakitchen.scene.configuration.base_fits`, the base's box against the furniture's
and obstacles' bounding boxes (conservative, as a costmap is). A stance the trial stood on
but the floor plan refuses is one no driven method can reach, the oracle included. Prints,
per robot: feasible configurations, successful stances, the share the floor plan refuses,
and the configurations where it refuses every one.
"""

from __future__ import annotations

import argparse
from collections import Counter
from pathlib import Path

import numpy as np
from analysis_cli import run_main

from momakitchen.data.reader import (
    dataset_generation,
    judged_configurations,
    rebuilt_configurations,
)
from momakitchen.robots.spec import get_robot_spec
from momakitchen.scene.configuration import base_fits


def refused_stances(data: Path) -> dict[str, Counter]:
    """Per robot: ``configurations`` (feasible), ``stances`` (successful trials),
    ``refused`` (of them, where the floor plan fits no base) and ``none_left``
    (configurations whose every successful stance is refused)."""
    manifest, gen = dataset_generation(data)
    todo = judged_configurations(data, manifest, "all", 0)
    out: dict[str, Counter] = {}
    for scene, shard, ci in rebuilt_configurations(data, todo, gen.scene):
        cfg, labels = scene.configurations[ci], shard.configuration(ci)
        ok = np.asarray(labels.trial_positions, np.float64)[np.asarray(labels.trial_stages) == 0]
        if not len(ok):
            continue
        fits = base_fits(scene.layout, cfg, ok, tuple(get_robot_spec(cfg.robot).footprint))
        row = out.setdefault(str(cfg.robot), Counter())
        row["configurations"] += 1
        row["stances"] += len(ok)
        row["refused"] += int((~fits).sum())
        row["none_left"] += int(not fits.any())
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, required=True, help="a simulator-backed dataset")
    args = ap.parse_args()
    print("robot | feasible configurations | successful stances | refused | none left")
    print("--- | ---: | ---: | ---: | ---:")
    for robot, c in sorted(refused_stances(args.data).items()):
        print(
            f"{robot} | {c['configurations']} | {c['stances']} | "
            f"{c['refused'] / c['stances']:.1%} | {c['none_left']}"
        )


if __name__ == "__main__":
    run_main(main, "planner_stances.py")
