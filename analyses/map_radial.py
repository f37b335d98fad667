"""Where a model's maps depart from the labels, by distance from the target.

    MOMAKITCHEN_ROBOT_YAML=pub/panda13.yaml python analyses/map_radial.py \
        --data ev/panda13 --split all --checkpoint body [--every N] [--json F]

`momakitchen evaluate` gives one PCC per robot; this says whether a low one is the map's
distance from the target or its shape at the right distance. Over the views whose label map
is not constant (a constant map scores PCC 0 whatever the prediction), with ``d`` each floor
point's horizontal distance from the target (the centroid of the view's target points, in
the robot's frame), per robot:

- ``pcc``: the model's PCC against the labels (the mean over these views);
- ``pcc_radial``: the PCC of the two maps each averaged over 5 cm rings of ``d``: how well
  the model places its values by distance alone;
- ``ceiling_radial``: the PCC against the labels of the labels' own ring averages: how much
  of the labels distance alone explains (a map that knew only how far to stand scores this);
- ``label_m``, ``pred_m``: the mean ``d`` of each map's mass (values as weights; medians
  over views), and ``shift_m``, the median of their difference per view (> 0: the model's
  mass stands farther out than the labels');
- ``mass``: the share of each map's mass in rings of 0.2 m (means over views).

It runs the model as ``evaluate`` does (the same inputs, gates and weights) and no trial.
"""

from __future__ import annotations

import argparse
import itertools
import json
from collections import defaultdict
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np
from analysis_cli import run_main

from momakitchen.errors import MomaError
from momakitchen.metrics import episode_metrics

RING = 0.05  # m: the rings the radial averages are taken over
BINS = (0.0, 0.4, 0.6, 0.8, 1.0, 1.2, np.inf)  # m: the mass table's rings
MASSES = ("label", "pred")


def ring_average(d: np.ndarray, values: np.ndarray, width: float = RING) -> np.ndarray:
    """Each point's value replaced by the mean over its ring of ``d`` (``width`` m).

    Shapes: ``d``, ``values`` (N,) -> (N,)
    """
    ring = np.floor(np.asarray(d) / width).astype(np.int64)
    _, inverse, counts = np.unique(ring, return_inverse=True, return_counts=True)
    sums = np.bincount(inverse, np.asarray(values, np.float64))
    return (sums / counts)[inverse]


def view_row(d: np.ndarray, pred: np.ndarray, label: np.ndarray) -> dict[str, Any] | None:
    """One view's figures (None where the label map is constant: nothing to score).

    Shapes: ``d``, ``pred``, ``label`` (N,) over the view's floor points.
    """
    d, pred, label = (np.asarray(a, np.float64) for a in (d, pred, label))
    if np.ptp(label) == 0:
        return None
    label_ring = ring_average(d, label)
    pred_sum, label_sum = pred.sum(), label.sum()
    pred_m = float((pred * d).sum() / pred_sum) if pred_sum > 0 else float("nan")
    label_m = float((label * d).sum() / label_sum)
    which = np.digitize(d, BINS[1:-1])
    return {
        "pcc": episode_metrics(pred, label)["pcc"],
        "pcc_radial": episode_metrics(ring_average(d, pred), label_ring)["pcc"],
        "ceiling_radial": episode_metrics(label_ring, label)["pcc"],
        "label_m": label_m,
        "pred_m": pred_m,
        "shift_m": pred_m - label_m,
        "label_mass": np.bincount(which, label, len(BINS) - 1) / label_sum,
        "pred_mass": np.bincount(which, pred, len(BINS) - 1) / max(pred_sum, 1e-300),
    }


def summarize(rows: Iterable[tuple[str, dict[str, Any]]]) -> dict[str, dict[str, Any]]:
    """Per robot: the means (PCCs, mass shares) and medians (distances) of its views' rows;
    ``rows`` are ``(robot, view_row)`` pairs."""
    by: dict[str, list[dict[str, Any]]] = defaultdict(list)
    for robot, row in rows:
        by[robot].append(row)
    out = {}
    for robot, rs in sorted(by.items()):
        col = {k: np.array([r[k] for r in rs]) for k in rs[0]}
        out[robot] = {
            "views": len(rs),
            **{k: round(float(col[k].mean()), 4) for k in ("pcc", "pcc_radial", "ceiling_radial")},
            **{k: round(float(np.nanmedian(col[k])), 3) for k in ("label_m", "pred_m", "shift_m")},
            "mass": {w: [round(float(v), 3) for v in col[f"{w}_mass"].mean(0)] for w in MASSES},
        }
    return out


def model_rows(args: argparse.Namespace) -> list[tuple[str, dict[str, Any]]]:
    """Run the checkpoint over the split's views (every ``--every``-th) as ``evaluate``
    does; ``(robot, view_row)`` per view whose labels are not constant."""
    import torch
    from torch.utils.data import Subset

    from momakitchen.data import EpisodeDataset
    from momakitchen.eval.evaluate import predicted_maps
    from momakitchen.models.reach_input import target_centroid
    from momakitchen.train.checkpoint import load_checkpoint

    if args.every < 1:
        raise MomaError(f"--every must be >= 1, got {args.every}")
    torch.set_num_threads(1)
    data = EpisodeDataset(args.data, args.split)
    if len(data) == 0:
        raise MomaError(f"{str(args.data)!r}: no {args.split} episodes")
    run = load_checkpoint(args.checkpoint)
    views = Subset(data, range(0, len(data), args.every))
    rows = []
    for batch, preds, labels in predicted_maps(run, views, progress=not args.quiet):
        mask = batch["floor_mask"].numpy()
        seen = ((batch["global_align"] > 0.5) & batch["global_mask"]).any(1).numpy()
        # the target's centre as the model's reachability input takes it
        centre = target_centroid(batch["global_xyz"], batch["global_align"], batch["global_mask"])
        for i, (pred, label) in enumerate(zip(preds, labels, strict=True)):
            if not seen[i]:
                continue
            floor = batch["floor_xyz"][i].numpy()[mask[i], :2]
            d = np.hypot(*(floor - centre[i, :2].numpy()).T)
            row = view_row(d, pred, label)
            if row is not None:
                rows.append((str(batch["robot_name"][i]), row))
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, required=True)
    ap.add_argument("--split", default="test", choices=("train", "test", "all"))
    ap.add_argument("--checkpoint", default="bundled", help="a run directory, bundled or body")
    ap.add_argument("--every", type=int, default=1, help="every N-th view of the split")
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--quiet", action="store_true")
    args = ap.parse_args()
    summary = summarize(model_rows(args))
    rings = " | ".join(f"{lo:.1f}-{hi:.1f}" for lo, hi in itertools.pairwise(BINS))
    head = "robot | views | pcc | pcc_radial | ceiling_radial | label_m | pred_m | shift_m"
    print(f"{head} | {rings} (label / model, % of mass)")
    for robot, s in summary.items():
        mass = " | ".join(
            f"{100 * a:.0f} / {100 * b:.0f}"
            for a, b in zip(s["mass"]["label"], s["mass"]["pred"], strict=True)
        )
        print(
            f"{robot} | {s['views']} | {s['pcc']:.3f} | {s['pcc_radial']:.3f} | "
            f"{s['ceiling_radial']:.3f} | {s['label_m']:.2f} | {s['pred_m']:.2f} | "
            f"{s['shift_m']:+.2f} | {mass}"
        )
    if args.json:
        args.json.write_text(json.dumps({"checkpoint": str(args.checkpoint), **summary}) + "\n")


if __name__ == "__main__":
    run_main(main, "map_radial.py")
