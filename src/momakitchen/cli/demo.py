"""``momakitchen demo``: the whole pipeline on one new kitchen, in under two minutes.

Builds a kitchen, renders the robot's first-person RGB-D view, predicts the navigation
affordance map with the bundled model, drives the base to the best point facing the
target and runs the manipulation there in physics, then labels the configuration's grid
of trials for comparison. Writes ``report.png`` and ``result.json``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from momakitchen.cli.common import (
    check_config_index,
    checked_run_dir,
    non_negative_int,
    planned_output_dir,
    scene_id,
)
from momakitchen.cli.options import add_checkpoint, add_robot_yaml

# momakitchen.generation.demo's default, spelled out so that building the parser
# (``momakitchen --help``) does not import numpy; tests/cli/test_main.py checks it.
DEFAULT_SCENE_ID = 900_001


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "demo", help="the main job: kitchen -> view -> model -> stop -> trial", description=__doc__
    )
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument(
        "--scene-id",
        type=scene_id,
        default=DEFAULT_SCENE_ID,
        help=f"kitchen to build (default {DEFAULT_SCENE_ID}, unseen in training)",
    )
    p.add_argument("--robot", default=None, help="robot (default: the configuration's own)")
    add_robot_yaml(p)
    p.add_argument(
        "--config",
        type=non_negative_int,
        default=0,
        help="configuration index within the scene (default 0)",
    )
    add_checkpoint(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from momakitchen.data.config import GenerationConfig
    from momakitchen.generation.demo import STEPS, run_demo

    # Everything that can be checked is checked before any work or any directory exists.
    if args.checkpoint is not None:
        checked_run_dir(args.checkpoint)
    check_config_index(args.config, GenerationConfig().scene.configs_per_scene)
    planned_output_dir(args.out)

    running: list[str] = []  # the step whose line awaits its duration

    def step(name: str, seconds: float | None) -> None:
        # "[2/6] render the first-person view ... 1.45 s": the step's own duration, the
        # number result.json records.
        if seconds is None:
            print(f"[{STEPS.index(name) + 1}/{len(STEPS)}] {name} ...", end="", flush=True)
            running.append(name)
        else:
            print(f" {seconds:.2f} s", flush=True)
            running.clear()

    try:
        result = run_demo(args.out, args.scene_id, args.robot, args.checkpoint, args.config, step)
    except BaseException:
        if running:  # end the step's line before the error is printed
            print(" failed", flush=True)
        raise
    trial = result["trial"]
    print(
        f"{result['robot']} -> {result['target']}: stopped at "
        f"x={result['chosen_pose_base_frame'][0]:.2f} y={result['chosen_pose_base_frame'][1]:.2f}"
        f" (affordance {result['predicted_affordance']:.2f}); trial "
        f"{'succeeded' if trial['success'] else 'failed: ' + trial['stage'].replace('_', ' ')}"
        f"; ground truth there {result['ground_truth_at_pose']:.2f}"
    )
    print(
        f"{result['seconds']['total']:.2f} s in all -> {Path(args.out) / 'report.png'}, "
        f"{Path(args.out) / 'result.json'}"
    )
    return 0
