"""How much a sensor augmentation blurs the training targets it teaches.

Noise-aware training (``EpisodeDataset.use_sensor_noise``) labels each rebuilt floor point
with the stored map *where the floor-corrected frame puts it*. The floor fit undoes the
camera's height and pitch errors but sees no turn about the vertical (yaw, and the part of
a roll a downward-looking camera makes one), nor a monocular depth's warp, so the rebuilt
scene is turned or moved against the labels: the physical floor point p is
taught the label of ``R p``, with ``R`` the residual of the believed camera pose (the
correction applied to the calibrated one) against the true one. A frame does not show
``R``, so a model trained this way can at best learn the mean target over the draws, even
for a clean frame. Per episode (every ``--every``-th of the ``--split``) and
augmentation, this script draws ``--draws`` corruptions exactly as training does and
reports, over the draws whose frame training can use (the rest, served clean, are left
out):

- ``shift_cm``: how far ``R`` moves the episode's stored floor points (median over
  points, then over draws and episodes);
- ``draw_pcc``: the PCC of one draw's taught map against the true one (mean);
- ``blur_pcc``: the PCC of the mean taught map (over the draws) against the true one
  (mean over episodes): the clean-frame PCC left to a perfect model of that training.

It runs no model and no trial; a mask error's move of the target is left out (see
``robustness_ceiling.py``).

    python analyses/label_blur.py --data DIR [--split train] [--every 400] [--draws 8] [--json F]
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from analysis_cli import run_main

RECIPES = Path(__file__).resolve().parents[1] / "scripts" / "recipes"


def mixes() -> dict[str, tuple[Callable[[np.random.Generator], Any], bool]]:
    """What is drawn per episode, and whether the draw is random: the training mixes, then
    single errors that say which part of a mix moves the labels."""
    from momakitchen.codec import load_config_file
    from momakitchen.perception.sensors import CalibrationError, Corruption, SensorAugmentation
    from momakitchen.train.config import TrainConfig

    def fixed(**kw: float) -> tuple[Callable[[np.random.Generator], Corruption], bool]:
        return (lambda rng: Corruption(calibration=CalibrationError(**kw))), False

    default = SensorAugmentation()
    mild = load_config_file(RECIPES / "sensor_noise_mild.yaml", TrainConfig).sensor_augmentation
    return {
        "default mix": (default.draw, True),
        "mild mix": (mild.draw, True),
        "default mix, no yaw": (replace(default, yaw=0.0).draw, True),
        "default mix, exact calibration": (replace(default, p_calibration=0.0).draw, True),
        "height +3 cm only": fixed(height=0.03),
        "pitch +3 deg only": fixed(pitch=3.0),
        "roll +3 deg only": fixed(roll=3.0),
        "yaw +1 deg only": fixed(yaw=1.0),
        "mono sensor only": ((lambda rng: Corruption(sensor="mono")), True),
    }


def main(argv: list[str] | None = None) -> None:
    from scipy.spatial import cKDTree

    from momakitchen.data import EpisodeDataset
    from momakitchen.data.episode import stored_frame
    from momakitchen.data.shard import SceneShard
    from momakitchen.data.torch_dataset import LABEL_RADIUS, NOISE_FIELDS, NOISE_KEEPS
    from momakitchen.errors import MomaError
    from momakitchen.frames import transform
    from momakitchen.metrics import episode_metrics
    from momakitchen.perception.live import frame_inputs
    from momakitchen.perception.sensors import SensorAugmentation, corrupt_frame

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", type=Path, required=True)
    ap.add_argument("--split", default="train", help="the episodes drawn from")
    ap.add_argument("--every", type=int, default=400, help="every N-th episode of the split")
    ap.add_argument("--draws", type=int, default=8)
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args(argv)
    if args.every < 1 or args.draws < 2:
        raise MomaError(f"--every must be >= 1 and --draws >= 2, got {args.every}, {args.draws}")
    data = EpisodeDataset(args.data, args.split)
    if len(data) == 0:
        raise MomaError(f"{args.data}: no {args.split} episodes")
    data.use_sensor_noise(SensorAugmentation())
    pre = data.preprocessing
    draws = mixes()
    rows: dict[str, list[dict]] = {name: [] for name in draws}
    for i in range(0, len(data), args.every):
        file, sid, c, e, _ = data.index[i]
        with SceneShard(args.data / file) as shard:
            a = shard.arrays(c, e, NOISE_KEEPS + NOISE_FIELDS)
        frame = stored_frame(a)
        floor = a["floor_xyz"].astype(np.float64)
        truth = a["floor_label"].astype(np.float64)
        if truth.std() == 0:  # no PCC to measure
            continue
        tree = cKDTree(floor[:, :2])
        # how far the optical axis (the camera's z) looks below the horizon
        down = float(np.degrees(np.arcsin(-frame.camera_to_base[2, 2])))
        for name, (draw, random) in draws.items():
            taught, shifts, pccs = [], [], []
            for k in range(args.draws if random else 1):  # a fixed error: one draw says all
                rng = np.random.default_rng([sid, c, e, k])
                corruption = draw(rng)
                bad = corrupt_frame(frame, corruption, rng)
                try:
                    clouds = frame_inputs(
                        bad.depth, bad.depth > 0, bad.rgb, bad.target_mask,
                        list(bad.obstacle_masks), bad.intrinsics, bad.camera_to_base,
                        pre.cloud, pre.max_depth, metric_depth=corruption.preset.depth.metric,
                    )  # fmt: skip
                except MomaError:
                    continue  # a frame training cannot use (it serves the clean sample)
                believed = clouds.correction.matrix @ bad.camera_to_base
                moved = transform(believed @ np.linalg.inv(frame.camera_to_base), floor)
                dist, near = tree.query(moved[:, :2], distance_upper_bound=LABEL_RADIUS)
                # floor moved off the stored map is left out of training: keep the truth there
                label = np.where(np.isfinite(dist), truth[np.minimum(near, len(truth) - 1)], truth)
                taught.append(label)
                shifts.append(float(np.median(np.linalg.norm((moved - floor)[:, :2], axis=1))))
                if label.std() > 0:
                    pccs.append(episode_metrics(label, truth)["pcc"])
            if not taught:
                continue
            blur = np.mean(taught, axis=0)
            rows[name].append(
                {
                    "view": [sid, c, e],
                    "camera_down_deg": down,
                    "shift_cm": 100 * float(np.median(shifts)),
                    "draw_pcc": float(np.mean(pccs)) if pccs else 1.0,
                    "blur_pcc": episode_metrics(blur, truth)["pcc"] if blur.std() > 0 else 0.0,
                }
            )

    def stat(rs: list[dict], key: str, how: Callable[..., Any], digits: int) -> float:
        return round(float(how([r[key] for r in rs])), digits)

    summary = {
        name: {
            "episodes": len(rs),
            "camera_down_deg_median": stat(rs, "camera_down_deg", np.median, 1),
            "shift_cm_median": stat(rs, "shift_cm", np.median, 2),
            "draw_pcc_mean": stat(rs, "draw_pcc", np.mean, 4),
            "blur_pcc_mean": stat(rs, "blur_pcc", np.mean, 4),
        }
        for name, rs in rows.items()
        if rs
    }
    for name, s in summary.items():
        print(f"{name:31s} {json.dumps(s)}")
    if args.json:
        args.json.write_text(json.dumps({"summary": summary, "episodes": rows}, indent=1) + "\n")


if __name__ == "__main__":
    run_main(main, "label_blur.py")
