"""The ground-truth label at each model's best point, on every view of the test split: an
offline view of closed-loop Top-1 with ten times the views `momakitchen msr` tries.

    python scripts/argmax_labels.py --data ~/mk-data/gt2-300 \
        --checkpoint ~/mk-runs/navaff ~/mk-runs/pointnet2

For every test episode each run scores the floor points as `evaluate` and `msr` do (the same
cloud down-sampling); its best point is MSR's Top-1 pick on that view. Prints, per run, the
mean label there and the share of views where it is >= 0.6 (where 95-100 % of closed-loop
trials succeed, docs/RESULTS.md), and the first run against each other paired by test scene
(Wilcoxon signed-rank test of the per-scene means: views of a scene are not independent).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from scipy.stats import wilcoxon

from momakitchen.data import EpisodeDataset
from momakitchen.errors import MomaError
from momakitchen.eval.evaluate import predicted_maps
from momakitchen.train.checkpoint import load_checkpoint


def argmax_labels(run_dir: Path, data: EpisodeDataset) -> dict[tuple[int, int, int], float]:
    """{(scene, configuration, episode): label at the predicted maximum} over ``data``."""
    out = {}
    for batch, preds, gts in predicted_maps(load_checkpoint(run_dir), data, progress=True):
        keys = zip(batch["scene_id"], batch["config_index"], batch["episode_index"], strict=True)
        for (sid, ci, ep), p, g in zip(keys, preds, gts, strict=True):
            out[int(sid), int(ci), int(ep)] = float(g[np.argmax(p)])
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, required=True)
    ap.add_argument("--checkpoint", type=Path, nargs="+", required=True)
    args = ap.parse_args()
    data = EpisodeDataset(args.data, "test")
    runs = {r.name: argmax_labels(r, data) for r in args.checkpoint}
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
    try:
        main()
    except MomaError as exc:  # bad input: one line, exit status 2, as the CLI does
        print(f"argmax_labels.py: error: {exc}", file=sys.stderr)
        sys.exit(2)
