"""``momakitchen generate``: the whole dataset, in parallel by scene, resumable.

Scenes ``S .. S+N-1`` become one HDF5 shard each under ``DIR/scenes``; ``DIR/manifest.json``
and the dataset card ``DIR/README.md`` are (re)written at the end. Killed runs resume:
run the same command again. ``--split test`` makes only the test scenes of the range (all
that ``evaluate`` and ``msr`` read); the same command without it adds the rest.
``--synthetic`` writes synthetic records of the same format in seconds (for smoke tests of
training pipelines); the manifest records the producer.

``--config FILE`` (YAML or JSON) sets generation options: any subset of the sections
``scene``, ``trial``, ``dense``, ``camera``, ``views`` and ``cloud`` and of their fields;
the rest keep their defaults. With ``--synthetic`` the file sets the fields of the
synthetic producer's config (``configs_per_scene``, ``episodes_per_config``, ...) instead.
Example:

    views:
      episodes: 4
    cloud:
      voxel: 0.03
    scene:
      robots: [ur10e, myarm]    # default: the paper's six
      mount_height: [0.6, 1.3]  # every robot's mount, drawn per configuration

``--preset NAME`` starts from a named set of options instead of the defaults (``hard``:
scenes where geometry is not enough to choose where the base stops; docs/DATASET.md,
"Presets"); a ``--config`` file's fields go on top of it, and the manifest records the
preset's name (``config.preset``).

``--robot NAME`` (repeatable) sets ``scene.robots``. User robots (``--robot-yaml FILE`` or
MOMAKITCHEN_ROBOT_YAML) are registered in every worker too, and the manifest records their
files by content hash.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from momakitchen.cli.common import positive_int, scene_id
from momakitchen.cli.options import add_quiet, add_robot_yaml
from momakitchen.errors import MomaError


def add_parser(sub: argparse._SubParsersAction) -> None:
    parser = sub.add_parser(
        "generate",
        help="generate the dataset (resumable, parallel)",
        description=__doc__,
        # Keep the docstring's line breaks: its YAML example is unreadable on one line.
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--out", required=True, help="dataset directory")
    parser.add_argument(
        "--scenes",
        type=positive_int,
        required=True,
        help="number of scenes (2 or more from scene 0 for both a train and a test split)",
    )
    parser.add_argument(
        "--first-scene-id",
        type=scene_id,
        default=0,
        help="first scene id (default 0; ids run to 2147483647)",
    )
    parser.add_argument(
        "--split",
        choices=("train", "test"),
        default=None,
        help="make only this split's scenes of the range (e.g. the test scenes, enough to "
        "evaluate a trained model); run again without it to add the rest",
    )
    parser.add_argument(
        "--workers",
        type=positive_int,
        default=1,
        help="parallel workers (processes; CPUs of a local Ray instance); a scene is the "
        "unit of work, so at most one worker per scene left to make",
    )
    parser.add_argument(
        "--backend",
        choices=("local", "ray"),
        default="local",
        help="local process pool (default) or Ray (RAY_ADDRESS or a local instance)",
    )
    parser.add_argument(
        "--synthetic",
        action="store_true",
        help="synthetic records instead of the simulator (format smoke tests)",
    )
    parser.add_argument(
        "--config",
        default=None,
        metavar="FILE",
        help="YAML or JSON file of generation options (any subset of the "
        "sections scene, trial, dense, camera, views, cloud; the rest "
        "default); with --synthetic, fields of the synthetic config",
    )
    parser.add_argument(
        "--preset",
        default="default",
        metavar="NAME",
        help="start from this named preset of generation options (default, hard; "
        "--config's fields go on top; recorded in the manifest)",
    )
    parser.add_argument(
        "--sensor",
        default=None,
        metavar="NAME",
        help="draw every view within this depth sensor's working range of the target "
        "(views.max_distance; `momakitchen robustness --list` names the sensors)",
    )
    parser.add_argument(
        "--robot",
        action="append",
        default=[],
        metavar="NAME",
        help="label with this robot (repeatable; sets the config's scene.robots, assigned "
        "round-robin over configurations; default: the paper's six)",
    )
    add_robot_yaml(parser)
    add_quiet(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from momakitchen.codec import load_config_file
    from momakitchen.data.generator import GenerateRequest, generate_dataset

    request = GenerateRequest(
        out=Path(args.out),
        num_scenes=args.scenes,
        first_scene_id=args.first_scene_id,
        workers=args.workers,
        backend=args.backend,
        split=args.split,
    )
    scene_fn: Any
    config: Any
    if args.synthetic:
        if args.sensor is not None:
            raise MomaError("--sensor sets where the simulator's views stand: not with --synthetic")
        if args.robot:
            raise MomaError("--robot sets the simulator's robots: not with --synthetic")
        if args.preset != "default":
            raise MomaError("--preset names the simulator's options: not with --synthetic")
        from momakitchen.data.synthetic_scene import SyntheticSceneConfig, synthetic_scene_records

        scene_fn = synthetic_scene_records
        config = (
            load_config_file(args.config, SyntheticSceneConfig)
            if args.config
            else SyntheticSceneConfig()
        )
    else:
        from momakitchen.codec import read_config_file
        from momakitchen.data.config import PRESETS, preset_config, unknown_preset

        if args.preset not in PRESETS:
            raise MomaError(unknown_preset(args.preset))
        # Read the file before loading the simulator: a bad file fails at once.
        if args.config:
            data = read_config_file(args.config)
            try:
                config = preset_config(args.preset, data)
            except MomaError as exc:
                raise MomaError(f"{args.config}: {exc}") from None
        else:
            config = preset_config(args.preset)
        if args.sensor is not None:
            import dataclasses

            from momakitchen.perception.sensors import get_sensor

            far = min(get_sensor(args.sensor).max_range, 20.0)
            config = dataclasses.replace(
                config, views=dataclasses.replace(config.views, max_distance=far)
            )
        if args.robot:
            import dataclasses

            # Checked as the config's own robots are (unknown names, counter reach).
            config = dataclasses.replace(
                config, scene=dataclasses.replace(config.scene, robots=tuple(args.robot))
            )
        from momakitchen.generation.producer import scene_records

        scene_fn = scene_records
    manifest = generate_dataset(request, scene_fn, config, progress=not args.quiet)
    from momakitchen.cli.wording import counted

    c = manifest["counts"]
    t = c["total"]
    print(
        f"{args.out}: {counted(t['scenes'], 'scene')}, "
        f"{counted(t['configurations'], 'configuration')}, {counted(t['episodes'], 'episode')} "
        f"(train {c['train']['episodes']}, test {c['test']['episodes']})"
        + ("" if manifest["complete"] else " - incomplete")
    )
    empty = [s for s in ("train", "test") if not c[s]["scenes"]]
    if empty and manifest["complete"] and args.split is None:
        from momakitchen.data.manifest import scenes_for_both_splits

        # A one-scene try-out is a test-only dataset, which `train` refuses: say so now.
        print(
            f"note: no {empty[0]} scenes (one scene id in 5 is a test scene); "
            f"--scenes {scenes_for_both_splits(args.first_scene_id)} or more from scene "
            f"{args.first_scene_id} gives both splits"
        )
    return 0
