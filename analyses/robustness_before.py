"""The robustness track through the real-robot path as it was before floor-plane inference:
the given extrinsics trusted, floor points ``z < floor_z`` with their measured heights fed
to the model, the target the mean of every point of its mask. For the "before" column of
docs/RESULTS.md's robustness table; everything else (views, corruptions, trials, metrics)
is ``momakitchen robustness``'s.

    python analyses/robustness_before.py --data DATA --json before.json \
        [--checkpoint RUN] [--corruption NAME ...] [--max-configs N]
"""

from __future__ import annotations

import argparse
import json
from typing import Any

import numpy as np
from analysis_cli import run_main

import momakitchen.perception.live as live
from momakitchen.errors import MomaError
from momakitchen.eval.robustness.tables import format_robustness_table
from momakitchen.eval.robustness.track import run_robustness
from momakitchen.eval.robustness.views import RobustnessConfig
from momakitchen.fileio import atomic_write_text
from momakitchen.perception.camera import CameraConfig
from momakitchen.perception.clouds import CloudConfig, frame_clouds


def trusting_frame_inputs(
    depth: np.ndarray,
    valid: np.ndarray,
    rgb: np.ndarray,
    target_mask: np.ndarray,
    obstacle_masks: Any,
    intrinsics: Any,
    camera_to_base: np.ndarray,
    cloud: CloudConfig | None = None,
    max_depth: float | None = None,
    **_: Any,
) -> dict[str, np.ndarray]:
    """The clouds as the earlier ``predict`` built them (no floor fit, no mask check)."""
    cloud = cloud or CloudConfig()
    max_depth = max_depth or CameraConfig().max_depth
    align = np.zeros(depth.shape, np.int8)
    for m in obstacle_masks:
        align[m] = -1
    align[target_mask] = 1
    g_xyz, g_rgb, g_align, f_xyz = frame_clouds(
        np.where(valid, depth, 0.0), rgb, align, intrinsics, camera_to_base, cloud, max_depth
    )
    if len(f_xyz) == 0:
        raise MomaError("no floor is visible (no point below the floor height)")
    if not (g_align > 0).any():
        raise MomaError("the target is beyond the depth range used")
    return {"global_xyz": g_xyz, "global_rgb": g_rgb, "global_align": g_align, "floor_xyz": f_xyz}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--json", required=True)
    ap.add_argument("--checkpoint", action="append", default=[])
    ap.add_argument("--corruption", action="append", default=[])
    ap.add_argument("--max-configs", type=int, default=0)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    config = RobustnessConfig(
        corruptions=tuple(args.corruption or ["clean"]),
        max_configs=args.max_configs,
        seed=args.seed,
    )
    live.frame_inputs = trusting_frame_inputs  # type: ignore[assignment]
    result = run_robustness(args.data, args.checkpoint, config, progress=True)
    result["pipeline"] = "before: extrinsics trusted, no floor-plane inference"
    atomic_write_text(args.json, json.dumps(result, indent=1) + "\n")
    print(format_robustness_table(result))


if __name__ == "__main__":
    run_main(main, "robustness_before.py")
