"""``momakitchen predict``: where should a real robot stop, from one RGB-D frame?

Inputs: a depth image (16-bit PNG in millimetres or .npy in metres; 0 and NaN are
invalid), the pinhole intrinsics, the camera-to-base transform (4x4, .npy or text), a
target mask from your own segmenter (PNG or .npy, non-zero = target), optional obstacle
masks and RGB, and the robot (a name, or --reach and --mount-height). Writes
``prediction.json`` (Top-k base poses x, y, yaw in the base frame, and every floor point
with its affordance and uncertainty) and ``prediction.png``.

Or, from a recorded ROS 2 bag: --bag PATH with --depth-topic and --camera-info-topic (the
camera-to-base transform comes from the bag's TF tree), --time SEC or --every N, and the
target mask as --target-mask FILE or --target-mask-topic; this also writes ``ros/``, a
ROS 2 bag (MCAP) of the poses, the map and RViz markers, and ``frames.json``, replacing
--out whole, and with --odom-frame FRAME fuses the frames' maps into one goal in FRAME
(needs the robot extra: pip install -e '.[robot]'; docs/ROBOT_IO.md).
"""

from __future__ import annotations

import argparse
import time
from typing import Any

from momakitchen.cli.common import checked_run_dir, output_dir, planned_output_dir
from momakitchen.cli.options import add_checkpoint, add_prediction, add_robot_yaml, config_fields
from momakitchen.cli.predict_bag import BAG_ONLY, add_bag_arguments, run_bag
from momakitchen.fileio import dumps_strict


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "predict",
        help="affordance map and base poses from a robot's RGB-D frame",
        description=__doc__,
    )
    p.add_argument("--depth", default=None, help="depth: 16-bit PNG (mm) or .npy (m)")
    p.add_argument(
        "--intrinsics",
        default=None,
        nargs=4,
        type=float,
        metavar=("FX", "FY", "CX", "CY"),
        help="pinhole intrinsics in pixels",
    )
    p.add_argument(
        "--extrinsics", default=None, help="camera-to-base 4x4 transform (.npy or whitespace text)"
    )
    p.add_argument("--target-mask", default=None, help="target mask (PNG or .npy)")
    p.add_argument(
        "--obstacle-mask", action="append", default=[], help="obstacle mask (repeatable)"
    )
    p.add_argument("--rgb", default=None, help="colour image (PNG or .npy), optional")
    p.add_argument("--robot", default=None, help="registered robot name (momakitchen robots)")
    add_robot_yaml(p)
    p.add_argument("--reach", type=float, default=None, help="arm reach (m), if no --robot")
    p.add_argument(
        "--mount-height",
        type=float,
        default=None,
        help="arm mount height (m): of --robot (default its own), or of a robot given by numbers",
    )
    p.add_argument(
        "--finger-force",
        type=float,
        default=None,
        help="the gripper's closing force per finger (N), with --reach (default 40)",
    )
    p.add_argument(
        "--shoulder-rise",
        type=float,
        default=None,
        help="the shoulder's height above the mount (m), with --reach (default 0.25)",
    )
    p.add_argument(
        "--shoulder-offset",
        type=float,
        default=None,
        help="the shoulder's distance from the first joint's axis (m), with --reach (default 0)",
    )
    add_checkpoint(p)
    add_prediction(p)
    p.add_argument("--out", required=True, help="output directory")
    add_bag_arguments(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from momakitchen.deploy.options import PredictOptions
    from momakitchen.deploy.predict import (
        load_depth,
        load_extrinsics,
        load_rgb,
        predict,
        write_outputs,
    )
    from momakitchen.errors import MomaError

    if args.robot is None and (args.reach is None or args.mount_height is None):
        raise MomaError("give --robot NAME, or both --reach and --mount-height")
    extra = {
        "finger_force": args.finger_force,
        "shoulder_rise": args.shoulder_rise,
        "shoulder_offset": args.shoulder_offset,
    }
    numbers = (args.reach, *extra.values())
    if args.robot is not None and any(n is not None for n in numbers):
        raise MomaError(
            "give either --robot [--mount-height] or --reach/--mount-height/--finger-force/"
            "--shoulder-*, not both"
        )
    if args.checkpoint is not None:
        checked_run_dir(args.checkpoint)
    robot: Any = args.robot or {
        "reach": args.reach,
        "mount_height": args.mount_height,
        **{k: v for k, v in extra.items() if v is not None},
    }
    if args.robot is not None and args.mount_height is not None:
        robot = (args.robot, args.mount_height)  # the registered robot at that mount
    out = planned_output_dir(args.out)
    # The model's options, the same for a frame from files and for a bag's frames.
    options = PredictOptions(**config_fields(args, PredictOptions))
    if args.bag is not None:
        return run_bag(args, robot, out, options)
    for flag, value in BAG_ONLY.items():
        if getattr(args, value) not in (None, [], False):
            raise MomaError(f"{flag} needs --bag")
    for flag in ("depth", "intrinsics", "extrinsics", "target_mask"):
        if getattr(args, flag) is None:
            raise MomaError(f"--{flag.replace('_', '-')} is required (or read a frame with --bag)")
    depth = load_depth(args.depth)
    rgb = load_rgb(args.rgb) if args.rgb else None
    extrinsics = load_extrinsics(args.extrinsics)
    t0 = time.perf_counter()
    pred = predict(
        depth,
        args.intrinsics,
        extrinsics,
        args.target_mask,
        robot,
        rgb=rgb,
        obstacle_masks=args.obstacle_mask,
        checkpoint=args.checkpoint,
        options=options,
    )
    seconds = time.perf_counter() - t0
    output_dir(out)  # created only now: a failed prediction leaves no empty directory
    paths = write_outputs(pred, out, rgb, depth, args.intrinsics, extrinsics)
    best = pred.to_dict(floor_points=False)["poses"]
    doc = pred.to_dict(floor_points=False)
    print(
        dumps_strict(
            {
                "poses": best,
                "floor_points": len(pred.floor_xyz),
                "floor_correction": doc["floor_correction"],
                "target_distance_m": doc["target_distance_m"],
                "seconds": round(seconds, 3),
            },
            indent=1,
        )
    )
    for warning in pred.warnings:
        print(f"warning: {warning}")
    print(f"-> {paths['json']}, {paths['png']}")
    return 0
