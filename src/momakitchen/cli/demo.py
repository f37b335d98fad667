"""``momakitchen demo``: the whole pipeline on one new kitchen, in under two minutes.

Builds a kitchen, renders the robot's first-person RGB-D view, predicts the navigation
affordance map with the bundled model, drives the base to the best point facing the
target and runs the manipulation there in physics, then labels the configuration's grid
of trials for comparison. Writes ``report.png`` and ``result.json``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from momakitchen.cli.common import non_negative_int, output_dir


def add_parser(sub: argparse._SubParsersAction) -> None:
    from momakitchen.generation.demo import DEFAULT_SCENE_ID

    p = sub.add_parser(
        "demo", help="the main job: kitchen -> view -> model -> stop -> trial", description=__doc__
    )
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument(
        "--scene-id",
        type=non_negative_int,
        default=DEFAULT_SCENE_ID,
        help=f"kitchen to build (default {DEFAULT_SCENE_ID}, unseen in training)",
    )
    p.add_argument("--robot", default=None, help="robot (default: the configuration's own)")
    p.add_argument(
        "--config",
        type=non_negative_int,
        default=0,
        help="configuration index within the scene (default 0)",
    )
    p.add_argument("--checkpoint", default=None, help="run directory (default: bundled model)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from momakitchen.errors import MomaError
    from momakitchen.generation.demo import STEPS, run_demo

    if args.checkpoint is not None and not Path(args.checkpoint).is_dir():
        raise MomaError(f"checkpoint directory {args.checkpoint!r} does not exist")
    t0 = time.perf_counter()

    def step(name: str) -> None:
        print(
            f"[{STEPS.index(name) + 1}/{len(STEPS)}] {name} ({time.perf_counter() - t0:.1f} s)",
            flush=True,
        )

    output_dir(args.out)
    result = run_demo(args.out, args.scene_id, args.robot, args.checkpoint, args.config, step)
    trial = result["trial"]
    print(
        f"{result['robot']} -> {result['target']}: stopped at "
        f"x={result['chosen_pose_base_frame'][0]:.2f} y={result['chosen_pose_base_frame'][1]:.2f}"
        f" (affordance {result['predicted_affordance']:.2f}); trial "
        f"{'succeeded' if trial['success'] else 'failed: ' + trial['stage'].replace('_', ' ')}"
        f"; ground truth there {result['ground_truth_at_pose']:.2f}"
    )
    print(
        f"{result['seconds']['total']:.1f} s -> {Path(args.out) / 'report.png'}, "
        f"{Path(args.out) / 'result.json'}"
    )
    return 0
