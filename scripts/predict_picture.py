"""The README's `predict` picture: one stored view as a real sensor with a miscalibrated
camera gives it, through the public real-robot path (`momakitchen.predict`, then
`write_outputs`), so the picture shows what a user gets.

    momakitchen generate --out dev --scenes 1 --first-scene-id 440003 --split test
    python scripts/predict_picture.py --data dev --sensor kinect --pitch 2 --out out/pred
    cp out/pred/prediction.png docs/img/predict.png
"""

from __future__ import annotations

import argparse

from script_cli import run_main

import momakitchen
from momakitchen import MomaError
from momakitchen.data.episode import episode_frame
from momakitchen.data.shard import SceneShard, list_shards
from momakitchen.deploy.predict import write_outputs
from momakitchen.perception.sensors import (
    CalibrationError,
    Corruption,
    corrupt_frame,
    corruption_rng,
)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--data", required=True, help="a generated dataset")
    p.add_argument("--scene-id", type=int, help="default: the dataset's first scene")
    p.add_argument("--config-index", type=int, default=0)
    p.add_argument("--episode-index", type=int, default=0)
    p.add_argument("--sensor", default="kinect", help="a sensor preset (robustness --list)")
    p.add_argument("--pitch", type=float, default=2.0, help="camera pitch error (deg, + up)")
    p.add_argument("--height", type=float, default=0.0, help="camera height error (m)")
    p.add_argument("--checkpoint", help="default: the bundled model")
    p.add_argument("--out", required=True)
    a = p.parse_args()

    shards = list_shards(a.data)
    if not shards:
        raise MomaError(f"--data {a.data} holds no scene shards")
    sid = a.scene_id if a.scene_id is not None else min(shards)
    if sid not in shards:
        raise MomaError(f"scene {sid} is not in {a.data} (it has {sorted(shards)})")
    with SceneShard(shards[sid]) as shard:
        episode = shard.episode(a.config_index, a.episode_index)
    robot = episode.robot
    corruption = Corruption(
        sensor=a.sensor, calibration=CalibrationError(height=a.height, pitch=a.pitch)
    )
    ids = (sid, a.config_index, a.episode_index)
    frame = corrupt_frame(episode_frame(episode), corruption, corruption_rng(0, ids, "picture"))
    pred = momakitchen.predict(
        frame.depth,  # 0 where the sensor gave nothing: predict ignores those pixels
        frame.intrinsics,
        frame.camera_to_base,
        frame.target_mask,
        robot,
        rgb=frame.rgb,
        obstacle_masks=list(frame.obstacle_masks),
        checkpoint=a.checkpoint,
        episode_id=ids,
        metric_depth=corruption.preset.depth.metric,
    )
    files = write_outputs(
        pred, a.out, frame.rgb, frame.depth, frame.intrinsics, frame.camera_to_base
    )
    correction = pred.correction.to_dict() if pred.correction else None
    print(f"scene {sid}, {robot}: floor correction {correction}")
    print("wrote " + ", ".join(str(f) for f in files.values()))


if __name__ == "__main__":
    run_main(main, "predict_picture.py")
