"""Photograph a labelling trial opening a door along its arc (docs/img/door_arc.png).

    python scripts/door_arc.py --scene-id 1009 --config 0 --out docs/img/door_arc.png

Runs the configuration's grid trials, in grid order, until one succeeds, then runs that
trial again (trials are deterministic) and renders the scene after every move of the pull.
"""

from __future__ import annotations

import argparse
import math
import textwrap
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from momakitchen.bullet import p
from momakitchen.perception.figures import DOC_WIDTH
from momakitchen.robots import get_robot_spec
from momakitchen.scene.configuration import sample_scene
from momakitchen.scene.geometry import semicircle_grid
from momakitchen.sim.trials import TrialRunner
from momakitchen.sim.world import World


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene-id", type=int, required=True)
    ap.add_argument("--config", type=int, required=True)
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args()
    scene = sample_scene(args.scene_id)
    if not 0 <= args.config < len(scene.configurations):
        ap.error(f"--config must be in [0, {len(scene.configurations) - 1}], got {args.config}")
    cfg = scene.configurations[args.config]
    if cfg.target.articulation is None:
        ap.error(f"configuration {args.config} targets a {cfg.target.category}, not a part")
    anchor = np.asarray(cfg.target.anchor)
    with World(scene.layout) as world:
        world.load_configuration(cfg)
        runner = TrialRunner(world, cfg.robot)
        target = runner.target
        grid = semicircle_grid(tuple(anchor[:2]), get_robot_spec(cfg.robot).reach, 0.1)
        base = next((xy for xy in grid if runner.run(*xy).success), None)
        if base is None:
            ap.error(f"no trial of configuration {args.config} succeeds")
        # A camera beside the robot, looking at the middle of the robot and the handle.
        towards = (base - anchor[:2]) / np.linalg.norm(base - anchor[:2])
        side = np.array([-towards[1], towards[0]])
        look = np.append((base + anchor[:2]) / 2, anchor[2] * 0.8)
        room = scene.layout.room
        for sign in (1.0, -1.0):  # the side with more room
            eye = look + np.append(1.4 * towards + sign * 1.0 * side, 0.8)
            if 0.1 < eye[0] < room.width - 0.1 and 0.1 < eye[1] < room.depth - 0.1:
                break
        view = p.computeViewMatrix(eye.tolist(), look.tolist(), [0, 0, 1])
        proj = p.computeProjectionMatrixFOV(55, 4 / 3, 0.05, 10)
        runner.base_free(*base)  # back to the saved state: the part closed
        closed = world.joint_position(target)
        frames: list[tuple[float, np.ndarray]] = []

        def photograph() -> None:
            rgb = p.getCameraImage(
                480, 360, view, proj, renderer=p.ER_TINY_RENDERER, physicsClientId=world.client
            )[2]
            opened = (world.joint_position(target) - closed) * target.open_direction
            frames.append((opened, np.asarray(rgb, np.uint8).reshape(360, 480, 4)[..., :3]))

        drive = runner._drive

        def filmed_drive(q_from: np.ndarray, q_to: np.ndarray, waypoints: int, steps: int) -> None:
            drive(q_from, q_to, waypoints, steps)
            photograph()

        runner._drive = filmed_drive  # type: ignore[method-assign]
        result = runner.run(*base)
    revolute = target.joint_type == "revolute"
    picks = [frames[round(i)] for i in np.linspace(0, len(frames) - 1, 4)]
    # Page width (DOC_WIDTH), two by two, so that its text is 9 pt where the docs show it.
    fig = Figure(figsize=(DOC_WIDTH, 0.78 * DOC_WIDTH))
    for ax, (opened, rgb) in zip(fig.subplots(2, 2).ravel(), picks, strict=True):
        ax.imshow(rgb)
        ax.set_axis_off()
        amount = f"{math.degrees(opened):.0f} deg" if revolute else f"{opened * 100:.0f} cm"
        ax.set_title(f"opened {amount}", fontsize=9)
    title = (
        f"scene {args.scene_id}, configuration {args.config}: {cfg.robot} opens the "
        f"{cfg.target.category} {target.part} from ({base[0]:.1f}, {base[1]:.1f}); "
        f"{'success' if result.success else 'failure'} (closed loop on the measured joint)"
    )
    fig.suptitle(textwrap.fill(title, 90), fontsize=9)
    fig.tight_layout()
    fig.savefig(args.out, dpi=120)
    print(f"{args.out}: {len(frames)} moves, opened {math.degrees(result.moved):.1f} deg")


if __name__ == "__main__":
    main()
