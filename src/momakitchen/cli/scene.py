"""``momakitchen scene``: build one kitchen, write ``scene.json`` and ``overview.png``."""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import TYPE_CHECKING

from momakitchen.cli.common import (
    check_config_index,
    non_negative_int,
    output_dir,
    planned_output_dir,
    positive_int,
    scene_id,
)
from momakitchen.cli.options import add_robot_yaml
from momakitchen.fileio import atomic_path, atomic_write_text, dumps_strict
from momakitchen.version import __version__

if TYPE_CHECKING:
    import numpy as np


def add_parser(sub: argparse._SubParsersAction) -> None:
    parser = sub.add_parser(
        "scene", help="build one kitchen: scene.json and an overview PNG", description=__doc__
    )
    parser.add_argument(
        "--scene-id",
        type=scene_id,
        required=True,
        help="scene id (an integer in [0, 2147483647]); everything derives from it",
    )
    parser.add_argument("--out", required=True, help="output directory")
    parser.add_argument(
        "--configs",
        type=positive_int,
        default=None,
        help="configurations to sample (default: SceneConfig default)",
    )
    parser.add_argument(
        "--config",
        type=non_negative_int,
        default=0,
        help="configuration shown in the overview plan (default 0)",
    )
    parser.add_argument(
        "--assets",
        default=None,
        help="external asset folder (<category>/<id>/mobility.urdf) to draw from",
    )
    parser.add_argument(
        "--no-render",
        action="store_true",
        help="skip the PyBullet build and rendered view (plan only)",
    )
    add_robot_yaml(parser)
    parser.set_defaults(func=run)


def view_pose(scene) -> tuple[np.ndarray, np.ndarray]:
    """A camera standing at the back of the room, looking at the counter."""
    import numpy as np

    room = scene.layout.room
    eye = np.array([room.width * 0.5, room.depth - 0.2, 1.9])
    target = np.array([room.width * 0.5, 0.3, 0.8])
    return eye, target


def run(args: argparse.Namespace) -> int:
    # Imported here so that `momakitchen --help` stays fast.
    from momakitchen.scene.configuration import SceneConfig, sample_scene
    from momakitchen.scene.overview import save_overview

    start = time.perf_counter()
    out = planned_output_dir(args.out)
    cfg = SceneConfig() if args.configs is None else SceneConfig(configs_per_scene=args.configs)
    check_config_index(args.config, cfg.configs_per_scene)
    if args.assets is not None:
        from momakitchen.assets.external import register_external_assets

        register_external_assets(Path(args.assets))
    scene = sample_scene(args.scene_id, cfg)
    record = {"generator": f"momakitchen {__version__}", **scene.to_dict()}
    view = None
    if not args.no_render:
        from momakitchen.generation.render import render
        from momakitchen.perception.camera import Intrinsics, look_at
        from momakitchen.sim.world import World

        with World(scene.layout) as world:
            world.load_configuration(scene.configurations[args.config])
            camera = look_at(*view_pose(scene))
            view = render(
                world.client, camera, Intrinsics.for_renderer(800, 600, 62.0), shadows=True
            ).rgb
    output_dir(out)  # created only now: a failed run leaves no empty directory
    atomic_write_text(out / "scene.json", dumps_strict(record, indent=1) + "\n")
    png = out / "overview.png"
    with atomic_path(png) as tmp:
        save_overview(scene, args.config, view, tmp)
    layout = scene.layout
    print(
        f"scene {layout.scene_id}: {layout.room.width:.2f} x {layout.room.depth:.2f} m room, "
        f"{len(layout.furniture)} units ({', '.join(u.category for u in layout.furniture)}), "
        f"{len(scene.configurations)} configurations -> {out}/scene.json, {png} "
        f"({time.perf_counter() - start:.1f} s)"
    )
    return 0
