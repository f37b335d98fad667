"""The ground-truth label at each model's best point, on every view of the test split: an
offline view of closed-loop Top-1 with ten times the views `momakitchen msr` tries.

    python analyses/argmax_labels.py --data ~/mk-data/gt2-300 \
        --checkpoint ~/mk-runs/navaff ~/mk-runs/pointnet2

For every test episode (every N-th with ``--every N``; one thread) each run scores the floor
points as `evaluate` and `msr` do (the same cloud down-sampling); its best point is MSR's
Top-1 pick on that view. Prints, per run, the mean label there and the share of views where
it is >= 0.6 (where 95-100 % of closed-loop trials succeed, docs/RESULTS.md), and the first
run against each other paired by test scene (Wilcoxon signed-rank test of the per-scene
means: views of a scene are not independent).
``--smooth R ...`` adds, per run and radius, the best point of the map averaged over R
metres (MSR's and predict's ``--pick-radius R``).
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from analysis_cli import add_view_args, run_main, test_views
from scipy.stats import wilcoxon
from torch.utils.data import Dataset

from momakitchen.eval.evaluate import predicted_maps
from momakitchen.models.inference import local_mean
from momakitchen.train.checkpoint import load_checkpoint


def argmax_labels(
    run_dir: Path, data: Dataset, radii: Sequence[float] = (0.0,)
) -> dict[float, dict[tuple[int, int, int], float]]:
    """{radius: {(scene, configuration, episode): label at the predicted maximum}} over
    ``data``; for a radius > 0 (m), the maximum of the map averaged over that radius (the
    ranking `msr` and `predict` use with their pick radius)."""
    out: dict[float, dict[tuple[int, int, int], float]] = {r: {} for r in radii}
    for batch, preds, gts in predicted_maps(load_checkpoint(run_dir), data, progress=True):
        keys = zip(batch["scene_id"], batch["config_index"], batch["episode_index"], strict=True)
        masks = batch["floor_mask"].numpy()
        for i, ((sid, ci, ep), p, g) in enumerate(zip(keys, preds, gts, strict=True)):
            xy = batch["floor_xyz"][i].numpy()[masks[i], :2]
            for r in radii:
                score = local_mean(xy, p, r) if r > 0 else p
                out[r][int(sid), int(ci), int(ep)] = float(g[np.argmax(score)])
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_view_args(ap, every=1)
    ap.add_argument(
        "--smooth",
        type=float,
        nargs="*",
        default=[],
        help="also pick on the map averaged over each of these radii (m)",
    )
    args = ap.parse_args()
    data = test_views(args)
    radii = (0.0, *(r for r in args.smooth if r > 0))
    runs = {}
    for run in args.checkpoint:
        for r, labels in argmax_labels(run, data, radii).items():
            runs[run.name + (f" (smoothed {r:g} m)" if r else "")] = labels
    keys = sorted(next(iter(runs.values())))
    print("| run | views | mean label at the best point | label >= 0.6 |")
    print("| --- | ---: | ---: | ---: |")
    for name, labels in runs.items():
        v = np.array([labels[k] for k in keys])
        print(f"| {name} | {len(v)} | {v.mean():.3f} | {np.mean(v >= 0.6):.1%} |")
    scenes = sorted({k[0] for k in keys})

    def per_scene(labels: dict) -> np.ndarray:
        return np.array([np.mean([labels[k] for k in keys if k[0] == s]) for s in scenes])

    first, *others = runs
    ref = per_scene(runs[first])
    for name in others:
        d = ref - per_scene(runs[name])
        print(
            f"{first} against {name}: higher in {(d > 0).sum()} of {len(d)} scenes, "
            f"lower in {(d < 0).sum()}; Wilcoxon p = {wilcoxon(d).pvalue:.2g}"
        )


if __name__ == "__main__":
    run_main(main, "argmax_labels.py")
