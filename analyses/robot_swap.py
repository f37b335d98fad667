"""How much each model's map depends on the robot: every test view scored once with its own
robot's descriptor and once with each other robot's.

    python analyses/robot_swap.py --data ~/mk-data/gt2-300 --every 20 \
        --checkpoint ~/mk-runs/navaff ~/mk-runs/pointnet2

Per run and robot, prints the PCC of the map with the label and the ground-truth label at
the map's best point (MSR's Top-1 pick), with the right descriptor and averaged over the
five wrong ones, and how far the map moves (mean |difference| over the mean of the map).
A model that ignored the robot would score the same either way.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import torch
from analysis_cli import add_view_args, run_main, test_views
from torch.utils.data import Subset

from momakitchen.data.batch import episode_maps
from momakitchen.eval.evaluate import predicted_maps
from momakitchen.metrics import episode_metrics
from momakitchen.models.inference import predict_batch
from momakitchen.robots.descriptor import robot_descriptor
from momakitchen.robots.spec import DEFAULT_ROBOTS, ROBOTS
from momakitchen.train.checkpoint import load_checkpoint


def pcc(pred: np.ndarray, label: np.ndarray) -> float:
    return episode_metrics(pred, label)["pcc"]


def swap_rows(run_dir: Path, data: Subset) -> list[tuple[str, float, float, float, float, float]]:
    """Per view: (robot, PCC right, PCC wrong, relative change, label at max right, wrong)."""
    run = load_checkpoint(run_dir)
    descs = {
        n: torch.tensor(robot_descriptor(ROBOTS.get_entry(n)), dtype=torch.float32)
        for n in DEFAULT_ROBOTS  # the robots datasets are made with by default
    }
    rows = []
    for batch, preds, labels in predicted_maps(run, data):
        swapped = {}
        for name, d in descs.items():
            other = {**batch, "robot": d.expand_as(batch["robot"]).clone()}
            swapped[name] = episode_maps(other, predict_batch(run.model, other))[0]
        for i, (p, g) in enumerate(zip(preds, labels, strict=True)):
            robot = batch["robot_name"][i]
            wrong = [swapped[n][i] for n in descs if n != robot]
            rows.append(
                (
                    robot,
                    pcc(p, g),
                    float(np.mean([pcc(w, g) for w in wrong])),
                    float(np.mean([np.abs(w - p).mean() for w in wrong]) / max(p.mean(), 1e-6)),
                    float(g[np.argmax(p)]),
                    float(np.mean([g[np.argmax(w)] for w in wrong])),
                )
            )
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_view_args(ap, every=20)
    args = ap.parse_args()
    subset = test_views(args)
    print(
        "| run | robot | views | PCC, own robot | PCC, other robots | map change | "
        "label at best point, own | other |"
    )
    print("| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    for run in args.checkpoint:
        rows = swap_rows(run, subset)
        for robot in ("all", *DEFAULT_ROBOTS):
            sel = np.array([r[1:] for r in rows if robot in ("all", r[0])], dtype=float)
            if len(sel):
                m = sel.mean(0)
                print(
                    f"| {run.name} | {robot} | {len(sel)} | {m[0]:.3f} | {m[1]:.3f} | "
                    f"{m[2]:.2f} | {m[3]:.3f} | {m[4]:.3f} |"
                )


if __name__ == "__main__":
    run_main(main, "robot_swap.py")
