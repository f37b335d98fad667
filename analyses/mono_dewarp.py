"""Can the floor tell monocular depth's warp at the target? (Only with an exact
calibration: docs/SENSORS.md.)

Relative depth gets one scale from the floor (``predict(..., metric_depth=False)``), and
the floor fit also levels the frame (pitch and roll). The depth's warp bends the floor
too, so the floor could tell more: this script takes the floor where the calibration
puts it, reads a smooth warp from it (a floor pixel at height z, after the one scale,
was measured ``(h - z) / h`` times its true depth; those ratios fitted robustly by a
quadratic over the image, clipped to the values seen on the floor), undoes it over the
whole frame and builds the model's input again. Per view (the views and corruption
draws of ``momakitchen robustness``), how far the apparent target lies from the clean
frame's, on the floor, with the one scale and with the warp undone. Runs no model.

    python analyses/mono_dewarp.py --data DIR [--corruption mono ...] [--seed 0]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
from analysis_cli import run_main

MIN_POINTS = 200  # floor pixels needed to read a warp


def _quadratic(u: np.ndarray, v: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    x, y = 2.0 * u / shape[1] - 1.0, 2.0 * v / shape[0] - 1.0
    return np.column_stack([np.ones_like(x), x, y, x * x, x * y, y * y])


def warp_field(bad, inputs, band: float = 0.1) -> np.ndarray | None:
    """The (H, W) factor that undoes the warp the floor shows, or None (too little floor).

    The floor is taken where the calibration puts it (z = 0 at the calibrated height h):
    after the one scale, a floor pixel at height z was measured ``(h - z) / h`` times its
    true depth. (A pitch or roll error of the calibration is then read as part of the
    warp: relative depth cannot tell the two apart.)"""
    from momakitchen.perception.clouds import cloud_in_base

    tf = bad.camera_to_base
    pts, idx = cloud_in_base(bad.depth, bad.intrinsics, tf, np.inf)
    cam, scale = tf[:3, 3], inputs.correction.scale
    pts = cam + scale * (pts - cam)
    h = float(cam[2])
    near = np.abs(pts[:, 2]) < band
    pts, idx = pts[near][::16], idx[near][::16]
    if len(idx) < MIN_POINTS:
        return None
    v, u = np.divmod(idx, bad.depth.shape[1])
    basis = _quadratic(u, v, bad.depth.shape)
    ratio = scale * h / (h - pts[:, 2])
    keep = np.ones(len(idx), bool)
    for _ in range(6):  # objects standing on the floor lie above it and drop out
        coef = np.linalg.lstsq(basis[keep], ratio[keep], rcond=None)[0]
        res = ratio - basis @ coef
        now = np.abs(res) <= max(3.0 * 1.4826 * float(np.median(np.abs(res[keep]))), 0.002)
        if now.sum() < MIN_POINTS or (now == keep).all():
            break
        keep = now
    seen = basis[keep] @ coef
    vv, uu = np.indices(bad.depth.shape)
    field = _quadratic(uu.reshape(-1), vv.reshape(-1), bad.depth.shape) @ coef
    return np.clip(field, seen.min(), seen.max()).reshape(bad.depth.shape)


def main() -> None:
    from dataclasses import replace

    from momakitchen.data.config import Preprocessing
    from momakitchen.data.episode import episode_frame
    from momakitchen.data.reader import dataset_generation, judged_configurations
    from momakitchen.eval.robustness.views import corrupted_view, judged_views
    from momakitchen.perception.live import frame_inputs

    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--data", type=Path, required=True)
    p.add_argument("--corruption", action="append", default=None)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--json", type=Path, default=None)
    args = p.parse_args()
    names = args.corruption or ["mono", "combined-mono"]

    manifest, gen = dataset_generation(args.data)
    pre = Preprocessing(gen.cloud, gen.camera.max_depth)
    todo = judged_configurations(args.data, manifest, "test", 0)
    rows: dict[str, list[dict]] = {n: [] for n in names}
    for scene, shard, ci, ep in judged_views(args.data, todo, gen, args.seed):
        ids = (scene.layout.scene_id, ci, ep)
        frame = episode_frame(shard.episode(ci, ep))
        clean = corrupted_view(frame, "clean", ids, pre, args.seed)[1]
        for name in names:
            bad, one = corrupted_view(frame, name, ids, pre, args.seed)
            if isinstance(clean, dict) or isinstance(one, dict):
                continue
            field = warp_field(bad, one)
            if field is None:
                continue
            fixed = replace(bad, depth=bad.depth * field)
            undone = frame_inputs(
                fixed.depth,
                np.isfinite(fixed.depth) & (fixed.depth > 0),
                fixed.rgb,
                fixed.target_mask,
                list(fixed.obstacle_masks),
                fixed.intrinsics,
                fixed.camera_to_base,
                pre.cloud,
                pre.max_depth,
                metric_depth=False,
            )
            dxy = [
                float(np.hypot(*(x.target_xyz[:2] - clean.target_xyz[:2]))) for x in (one, undone)
            ]
            rows[name].append({"view": list(ids), "one_scale_m": dxy[0], "dewarped_m": dxy[1]})
    summary = {}
    for name, rs in rows.items():
        a = np.array([[r["one_scale_m"], r["dewarped_m"]] for r in rs]).reshape(-1, 2)
        summary[name] = {
            "views": len(rs),
            "median_m": [round(float(x), 4) for x in np.median(a, axis=0)] if len(rs) else None,
            "mean_m": [round(float(x), 4) for x in a.mean(axis=0)] if len(rs) else None,
            "dewarped_closer": int((a[:, 1] < a[:, 0]).sum()),
        }
        print(name, "(one scale, dewarped):", json.dumps(summary[name]))
    if args.json:
        args.json.write_text(json.dumps({"summary": summary, "views": rows}, indent=1))


if __name__ == "__main__":
    run_main(main, "mono_dewarp.py")
