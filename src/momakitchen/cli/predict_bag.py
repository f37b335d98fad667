"""``momakitchen predict --bag``: the frames of a recorded ROS 2 bag.

The options here join ``momakitchen predict``'s; every selected frame of the bag is read,
paired and checked (topics, encodings, sizes, camera info, masks, TF) before the model
runs, and the output directory is replaced, whole, only when every frame has a prediction
(:mod:`momakitchen.deploy.bagoutputs`). With ``--odom-frame`` the frames' maps are also
fused in the odometry frame into one goal.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from momakitchen.cli.common import non_negative_float, positive_float, positive_int

if TYPE_CHECKING:
    from momakitchen.deploy.options import PredictOptions

# Bag-only option -> its attribute (checked to be unset without --bag).
BAG_ONLY = {
    "--depth-topic": "depth_topic",
    "--camera-info-topic": "camera_info_topic",
    "--rgb-topic": "rgb_topic",
    "--target-mask-topic": "target_mask_topic",
    "--obstacle-mask-topic": "obstacle_mask_topic",
    "--base-frame": "base_frame",
    "--time": "time",
    "--every": "every",
    "--max-dt": "max_dt",
    "--odom-frame": "odom_frame",
}
# Options of the frame-from-files form that a bag replaces.
FILE_ONLY = {
    "--depth": "depth",
    "--intrinsics": "intrinsics",
    "--extrinsics": "extrinsics",
    "--rgb": "rgb",
    "--obstacle-mask": "obstacle_mask",
}
DEFAULT_MAX_DT = 0.05


def add_bag_arguments(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group(
        "from a ROS 2 bag (pip install -e '.[robot]')",
        "a bag directory (.db3 or .mcap storage) or a .mcap file; the camera-to-base "
        "transform is composed from /tf_static and /tf at each depth frame's stamp",
    )
    g.add_argument("--bag", default=None, help="ROS 2 bag directory or .mcap file")
    g.add_argument("--depth-topic", default=None, help="depth image topic (16UC1 mm or 32FC1 m)")
    g.add_argument("--camera-info-topic", default=None, help="the depth image's CameraInfo topic")
    g.add_argument("--rgb-topic", default=None, help="colour topic (Image or CompressedImage)")
    g.add_argument("--target-mask-topic", default=None, help="target mask topic (mono8 image)")
    g.add_argument(
        "--obstacle-mask-topic", action="append", default=None, help="obstacle mask topic"
    )
    g.add_argument(
        "--base-frame", default=None, help="the robot's base frame (default base_link; z=0 floor)"
    )
    g.add_argument(
        "--time",
        type=non_negative_float,
        default=None,
        metavar="SEC",
        help="the depth frame nearest SEC seconds after the bag's start",
    )
    g.add_argument(
        "--every", type=positive_int, default=None, metavar="N", help="every Nth depth frame"
    )
    g.add_argument(
        "--max-dt",
        type=positive_float,
        default=None,
        metavar="SEC",
        help=f"pair colour and masks within SEC of the depth stamp (default {DEFAULT_MAX_DT})",
    )
    g.add_argument(
        "--odom-frame",
        default=None,
        metavar="FRAME",
        help="also fuse the frames' maps in this odometry frame (e.g. odom; TF FRAME -> the "
        "base frame at each frame's stamp) into one goal, a PoseStamped in FRAME",
    )


def run_bag(args: argparse.Namespace, robot: Any, out: Path, options: PredictOptions) -> int:
    """Predict on the bag's selected frames and write their outputs into ``out``.

    Every frame is checked before the model runs; the frames are then read, predicted and
    written one at a time into a hidden directory beside ``out``, which replaces ``out``
    when all are there (a failure leaves ``out`` as it was).
    """
    from momakitchen.deploy.bagoutputs import BagOutputs, check_replaceable
    from momakitchen.deploy.rosbag import BagFrames, BagTopics, check_bag_path, predict_frames
    from momakitchen.deploy.rosbag import typestore as require_robot_extra
    from momakitchen.errors import MomaError

    for flag, value in FILE_ONLY.items():
        if getattr(args, value) not in (None, []):
            raise MomaError(f"{flag} cannot be used with --bag (the bag's topics give it)")
    for flag in ("--depth-topic", "--camera-info-topic"):
        if getattr(args, BAG_ONLY[flag]) is None:
            raise MomaError(f"--bag needs {flag}")
    if (args.time is None) == (args.every is None):
        raise MomaError("--bag needs either --time SEC or --every N to choose its frames")
    if (args.target_mask is None) == (args.target_mask_topic is None):
        raise MomaError("--bag needs either --target-mask FILE or --target-mask-topic")
    check_bag_path(args.bag)
    require_robot_extra()
    check_replaceable(out)  # before any work: the outputs replace out whole
    topics = BagTopics(
        depth=args.depth_topic,
        camera_info=args.camera_info_topic,
        rgb=args.rgb_topic,
        target_mask=args.target_mask_topic,
        obstacle_masks=tuple(args.obstacle_mask_topic or ()),
        base_frame=args.base_frame or "base_link",
        max_dt=DEFAULT_MAX_DT if args.max_dt is None else args.max_dt,
        odom_frame=args.odom_frame,
    )
    t0 = time.perf_counter()
    with BagFrames(
        args.bag, topics, time=args.time, every=args.every, target_mask=args.target_mask
    ) as frames:
        print(f"{len(frames)} frame(s) of {args.bag} checked", flush=True)
        preds = predict_frames(frames, robot, checkpoint=args.checkpoint, options=options)
        with BagOutputs(
            out,
            single=args.time is not None,
            odom_frame=topics.odom_frame,
            pick_radius=options.pick_radius,
        ) as outputs:
            for frame, pred in preds:
                best = outputs.add(frame, pred)["poses"][0]
                print(
                    f"frame {frame.index} t={frame.stamp:.3f} s: best pose "
                    f"x={best['x']:.3f} y={best['y']:.3f} yaw={best['yaw']:.3f} "
                    f"(affordance {best['affordance']:.2f})",
                    flush=True,
                )
            doc = outputs.finish({"bag": str(Path(args.bag)), "topics": vars(topics)})
    seconds = time.perf_counter() - t0
    if outputs.leftover is not None:
        print(f"warning: the previous outputs could not all be removed: {outputs.leftover}")
    fused = doc.get("fused")
    if fused is not None:
        goal = fused["goal"]
        where = (
            "no goal"
            if goal is None
            else f"x={goal['x']:.3f} y={goal['y']:.3f} yaw={goal['yaw']:.3f}"
        )
        print(f"fused goal of {fused['looks']} frame(s) in {fused['frame']!r}: {where}")
    print(
        f"{len(doc['frames'])} frame(s) in {seconds:.2f} s -> {out / 'frames.json'}, {out / 'ros'}/"
    )
    return 0
