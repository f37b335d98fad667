"""How well any model could do under each corruption, from the geometry alone.

A corruption that moves the target in the frame the robot believes (a shifted mask, a
warped monocular depth) moves the whole map a perfect model would predict: such a model,
given the corrupted frame, predicts the truth around the *apparent* target. This script
measures, per view (the same views and corruption draws as ``momakitchen robustness``):

- ``dxy``: how far the apparent target (``FrameClouds.target_xyz``) lies from the clean
  frame's target, on the floor (m);
- ``ceiling_pcc``: the PCC between the true map at the corrupted frame's floor points and
  the true map shifted by that displacement (the map a perfect model would give);

then the medians and means over the views. It runs no model and no trial.

    python analyses/robustness_ceiling.py --data DIR [--corruption NAME ...] [--json F]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np


def main(argv: list[str] | None = None) -> int:
    from momakitchen.data.config import Preprocessing
    from momakitchen.data.episode import episode_frame
    from momakitchen.data.reader import (
        dataset_generation,
        judged_configurations,
        judged_view,
        rebuilt_configurations,
    )
    from momakitchen.eval.robustness.views import view_inputs
    from momakitchen.metrics import episode_metrics
    from momakitchen.sim.labels import floor_affordance

    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--data", required=True)
    p.add_argument("--corruption", action="append", default=None)
    p.add_argument("--split", default="test")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--json", default=None)
    args = p.parse_args(argv)
    names = args.corruption or ["shift10", "mono", "erode5", "dilate5", "kinect", "combined"]

    root = Path(args.data)
    manifest, gen = dataset_generation(root)
    pre = Preprocessing(gen.cloud, gen.camera.max_depth)
    todo = judged_configurations(root, manifest, args.split, 0)
    rows: dict[str, list[dict]] = {n: [] for n in names}
    for scene, shard, ci in rebuilt_configurations(root, todo, gen.scene):
        sid = scene.layout.scene_id
        ep = judged_view(shard, scene, ci, args.seed)
        if ep is None:
            continue
        labels = shard.configuration(ci)
        cfg = scene.configurations[ci]
        episode = shard.episode(ci, ep)
        frame = episode_frame(episode)
        grid = SimpleNamespace(positions=labels.trial_positions, outcomes=labels.trial_outcomes)
        clean = view_inputs(frame, "clean", (sid, ci, ep), pre, args.seed)
        if isinstance(clean, dict):
            continue
        for name in names:
            bad = view_inputs(frame, name, (sid, ci, ep), pre, args.seed)
            if isinstance(bad, dict):
                rows[name].append({"view": [sid, ci, ep], "status": bad["status"]})
                continue
            q = bad.floor_xyz[:, :2]
            shift = bad.target_xyz[:2] - clean.target_xyz[:2]
            truth = [
                floor_affordance(grid, scene.layout, cfg, at, episode.base_pose, gen.dense)
                for at in (q - shift, q)
            ]
            m = episode_metrics(truth[0].astype(np.float64), truth[1].astype(np.float64))
            rows[name].append(
                {
                    "view": [sid, ci, ep],
                    "status": "ok",
                    "target": cfg.target.category,
                    "dxy": round(float(np.hypot(*shift)), 4),
                    "ceiling_pcc": round(float(m["pcc"]), 4),
                }
            )
    summary = {}
    for name, rs in rows.items():
        ok = [r for r in rs if r["status"] == "ok"]
        d = np.array([r["dxy"] for r in ok]) if ok else np.zeros(0)
        c = np.array([r["ceiling_pcc"] for r in ok]) if ok else np.zeros(0)
        summary[name] = {
            "views": len(rs),
            "ok": len(ok),
            "dxy_median_m": round(float(np.median(d)), 4) if ok else None,
            "dxy_mean_m": round(float(d.mean()), 4) if ok else None,
            "dxy_over_5cm": int((d > 0.05).sum()),
            "ceiling_pcc_mean": round(float(c.mean()), 4) if ok else None,
        }
        print(name, json.dumps(summary[name]))
    if args.json:
        Path(args.json).write_text(json.dumps({"summary": summary, "views": rows}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
