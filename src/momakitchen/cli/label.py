"""``momakitchen label``: run the trials of one configuration and write its labels.

Writes ``labels.npz`` (grid positions, yaws, outcomes, failure stage, the grasp executed and
what moved per position), ``labels.json`` (summary: counts per stage and per grasp, success
rate, timing, and ``rejections``: the stages that turned away most of the positions reaching
them, with the colliding links or execution failures most often behind it) and
``labels.png`` (outcomes by stage next to the dense map). The same stage counts and
rejections are printed.
"""

from __future__ import annotations

import argparse
import dataclasses

from momakitchen.cli.common import (
    check_config_index,
    non_negative_float,
    non_negative_int,
    output_dir,
    planned_output_dir,
    positive_float,
    scene_id,
)
from momakitchen.cli.options import add_quiet, add_robot_yaml
from momakitchen.fileio import (
    atomic_path,
    atomic_write_bytes,
    atomic_write_text,
    dumps_strict,
    npz_bytes,
)
from momakitchen.version import __version__


def add_parser(sub: argparse._SubParsersAction) -> None:
    parser = sub.add_parser(
        "label", help="run the trials of a configuration: labels + PNG", description=__doc__
    )
    parser.add_argument("--scene-id", type=scene_id, required=True)
    parser.add_argument(
        "--robot", default=None, help="robot to label with (default: the configuration's own robot)"
    )
    add_robot_yaml(parser)
    parser.add_argument(
        "--config",
        type=non_negative_int,
        default=0,
        help="configuration index within the scene (default 0)",
    )
    parser.add_argument("--out", required=True, help="output directory")
    parser.add_argument(
        "--target-mass",
        type=positive_float,
        default=None,
        help="override the target's mass in kg (what-if study)",
    )
    parser.add_argument(
        "--target-friction",
        type=non_negative_float,
        default=None,
        help="override the target's lateral friction (what-if study)",
    )
    add_quiet(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import numpy as np
    from tqdm import tqdm

    from momakitchen.scene.configuration import (
        SceneConfig,
        sample_scene,
        usable_robot,
        with_robot,
    )
    from momakitchen.sim.config import STAGE_NAMES, DenseMapConfig, TrialConfig
    from momakitchen.sim.label_figure import save_label_figure
    from momakitchen.sim.labels import label_configuration, rejections
    from momakitchen.sim.world import World

    scene_cfg = SceneConfig()
    if args.robot is not None:  # unknown names, and arms that reach no counter, fail first
        usable_robot(args.robot, scene_cfg)
    check_config_index(args.config, scene_cfg.configs_per_scene)
    out = planned_output_dir(args.out)
    scene = sample_scene(args.scene_id, scene_cfg)
    cfg = scene.configurations[args.config]
    if args.robot is not None:
        # The same configuration (objects, target, obstacles), labelled by another robot
        # (at its own mount height for it).
        cfg = with_robot(cfg, args.robot, scene_cfg)
    trial_cfg = TrialConfig()
    with (
        World(scene.layout) as world,
        tqdm(
            desc=f"scene {args.scene_id} config {args.config} ({cfg.robot})",
            unit="trial",
            disable=args.quiet,
            leave=False,
        ) as bar,
    ):

        def progress(done: int, total: int) -> None:
            bar.total = total
            bar.update(done - bar.n)

        labels = label_configuration(
            world,
            cfg,
            trial_config=trial_cfg,
            grid_spacing=scene_cfg.grid_spacing,
            target_mass=args.target_mass,
            target_friction=args.target_friction,
            progress=progress,
            diagnose=True,  # the rejection lines say which joints stop IK
        )
    output_dir(out)  # created only now: a failed run leaves no empty directory
    data = npz_bytes(
        positions=labels.positions,
        yaws=labels.yaws,
        outcomes=labels.outcomes,
        stages=labels.stages,
        moved=labels.moved,
        grasps=np.array(labels.grasps, dtype=str),
        anchor=np.asarray(labels.anchor),
        stage_names=np.array(STAGE_NAMES),
    )
    atomic_write_bytes(out / "labels.npz", data)
    rejected = rejections(labels)
    summary = {
        "generator": f"momakitchen {__version__}",
        **labels.summary(),
        "rejections": [dataclasses.asdict(r) for r in rejected],
        "overrides": {"target_mass": args.target_mass, "target_friction": args.target_friction},
        "trial_config": dataclasses.asdict(trial_cfg),
        "dense_map": dataclasses.asdict(DenseMapConfig()),
    }
    atomic_write_text(out / "labels.json", dumps_strict(summary, indent=1) + "\n")
    with atomic_path(out / "labels.png") as tmp:
        save_label_figure(scene.layout, cfg, labels, tmp)
    s = labels.summary()
    print(
        f"scene {args.scene_id} config {args.config}: {cfg.robot} -> {labels.target}: "
        f"{s['successes']}/{s['positions']} positions succeed "
        f"({s['physics_trials']} executed in physics), {labels.seconds['total']:.1f} s -> "
        f"{out}/labels.npz, labels.json, labels.png"
    )
    counts = ", ".join(f"{k} {v}" for k, v in s["stages"].items() if v)
    print(f"  stages: {counts}")
    for r in rejected:  # why a stage turned most positions away: which links collide
        print(f"  {r.line()}")
    return 0
