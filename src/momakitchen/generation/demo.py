"""The end-to-end demo: a new kitchen, a robot's first-person view, the bundled model's
affordance map, the chosen base pose executed as a trial in physics, and a report."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from momakitchen.errors import MomaError
from momakitchen.fileio import dumps_strict

DEMO_VIEWS = 4  # viewpoints sampled; the demo uses the farthest
DEFAULT_SCENE_ID = 900_001  # far above the ids of generated datasets: a kitchen no model saw
STEPS = (
    "build the kitchen",
    "render the first-person view",
    "predict the affordance map",
    "drive there and run the trial",
    "label the ground truth (grid of trials)",
    "write the report",
)
# The name of each step's duration in result.json's "seconds" (with "total", their sum).
STEP_KEYS = ("build", "render", "predict", "trial", "labels", "report")


def run_demo(
    out_dir: str | Path,
    scene_id: int = DEFAULT_SCENE_ID,
    robot: str | None = None,
    checkpoint: str | Path | None = None,
    config_index: int = 0,
    step: Callable[[str, float | None], None] | None = None,
) -> dict[str, Any]:
    """Run the demo; writes ``report.png`` and ``result.json`` into ``out_dir`` (created
    only then: a run that fails leaves nothing behind).

    ``step(name, None)`` is called as each of ``STEPS`` starts and ``step(name, seconds)``
    as it ends, ``seconds`` being its own duration as ``result.json`` records it (progress
    display). Returns the content of ``result.json``.
    """
    from momakitchen.data.config import GenerationConfig
    from momakitchen.data.episode import SEMANTIC_CLASSES
    from momakitchen.fileio import atomic_write_bytes, atomic_write_text
    from momakitchen.frames import base_to_world, base_to_world_xy
    from momakitchen.generation.producer import sample_views
    from momakitchen.models.inference import predict_map
    from momakitchen.perception.live import frame_inputs
    from momakitchen.robots import get_robot_spec
    from momakitchen.robots.descriptor import robot_descriptor
    from momakitchen.scene.configuration import sample_scene, usable_robot, with_robot
    from momakitchen.sim.config import Stage
    from momakitchen.sim.labels import floor_affordance, label_configuration
    from momakitchen.sim.trials import TrialRunner
    from momakitchen.sim.world import World
    from momakitchen.train.checkpoint import default_checkpoint, load_checkpoint

    report_step = step or (lambda name, seconds: None)
    config = GenerationConfig()
    if robot is not None:
        # Unknown names, and robots that cannot reach a counter, fail before any work.
        usable_robot(robot, config.scene)
    out = Path(out_dir)
    run = load_checkpoint(checkpoint if checkpoint is not None else default_checkpoint())
    seconds: dict[str, float] = {}
    started = {"total": time.perf_counter()}

    def begin(i: int) -> None:
        started["step"] = time.perf_counter()
        report_step(STEPS[i], None)

    def end(i: int) -> None:
        seconds[STEP_KEYS[i]] = round(time.perf_counter() - started["step"], 2)
        report_step(STEPS[i], seconds[STEP_KEYS[i]])

    begin(0)
    scene = sample_scene(scene_id, config.scene)
    if not 0 <= config_index < len(scene.configurations):
        raise MomaError(
            f"configuration index must be in [0, {len(scene.configurations) - 1}],"
            f" got {config_index}"
        )
    cfg = scene.configurations[config_index]
    if robot is not None:
        cfg = with_robot(cfg, robot, config.scene)
    with World(scene.layout) as world:
        world.load_configuration(cfg)
        end(0)
        begin(1)
        # Views come in order of increasing distance; the farthest of a few sees the most
        # floor around the target.
        views = sample_views(
            world,
            scene.layout,
            cfg,
            dataclasses.replace(
                config, views=dataclasses.replace(config.views, episodes=DEMO_VIEWS)
            ),
        )
        if not views:
            raise MomaError(
                f"scene {scene_id}: no viewpoint sees the target; try another --scene-id"
            )
        view = views[-1]
        base, camera_to_world, frame, sem = (
            view.base,
            view.camera_to_world,
            view.frame,
            view.semantic,
        )
        camera_to_base = np.linalg.inv(base_to_world(base)) @ camera_to_world
        intr = config.camera.intrinsics
        end(1)

        begin(2)
        # The frame goes through the same path as a real robot's (momakitchen.predict).
        depth = frame.depth.astype(np.float32)
        clouds = frame_inputs(
            depth,
            np.isfinite(depth) & (depth > 0),
            frame.rgb,
            sem == SEMANTIC_CLASSES.index("target"),
            [sem == SEMANTIC_CLASSES.index("obstacle")],
            intr,
            camera_to_base,
            run.preprocessing.cloud,
            run.preprocessing.max_depth,
        )
        pred = predict_map(
            run,
            clouds,
            cfg.robot,
            np.asarray(robot_descriptor(get_robot_spec(cfg.robot), cfg.mount_height), np.float32),
            opens=cfg.target.is_articulated,
        )
        end(2)

        begin(3)
        world_xy = base_to_world_xy(pred.poses[:, :2], base)
        runner = TrialRunner(world, cfg.robot, config.trial)
        try:
            trial = runner.run(*world_xy[0])
        finally:
            runner.close()
        end(3)

        begin(4)
        labels = label_configuration(
            world, cfg, trial_config=config.trial, grid_spacing=config.scene.grid_spacing
        )
        gt = floor_affordance(labels, scene.layout, cfg, pred.floor_xyz[:, :2], base, config.dense)
        end(4)

    begin(5)
    outcome = (
        "success"
        if trial.success
        else f"failure ({Stage(trial.stage).name.lower().replace('_', ' ')})"
    )
    result = {
        "scene_id": scene_id,
        "config_index": config_index,
        "robot": cfg.robot,
        "mount_height": cfg.mount,
        "target": labels.target,
        "model": run.config.model,
        "checkpoint": str(checkpoint) if checkpoint is not None else "bundled",
        "viewpoint_base_pose_world": [round(float(v), 4) for v in base],
        "chosen_pose_base_frame": [round(float(v), 4) for v in pred.poses[0]],
        "chosen_position_world": [round(float(v), 4) for v in world_xy[0]],
        "predicted_affordance": round(float(pred.pose_scores[0]), 4),
        "uncertainty": round(float(pred.pose_uncertainty[0]), 4),
        "ground_truth_at_pose": round(
            float(gt[int(np.argmin(np.hypot(*(pred.floor_xyz[:, :2] - pred.poses[0, :2]).T)))]), 4
        ),
        "trial": {
            "success": bool(trial.success),
            "stage": Stage(trial.stage).name.lower(),
            "moved": round(float(trial.moved), 4),
        },
        "grid": {"trials": len(labels.positions), "successes": int(labels.outcomes.sum())},
        "seconds": seconds,
    }
    png = report_figure(
        frame.rgb,
        frame.depth,
        sem == SEMANTIC_CLASSES.index("target"),
        intr,
        camera_to_base,
        pred,
        gt,
        outcome,
        result,
    )
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(out / "report.png", png)
    seconds["report"] = round(time.perf_counter() - started["step"], 2)
    seconds["total"] = round(time.perf_counter() - started["total"], 2)
    atomic_write_text(out / "result.json", dumps_strict(result, indent=1) + "\n")
    report_step(STEPS[5], seconds["report"])
    return result


def report_region(
    floor_xyz: np.ndarray,
    maps: list[np.ndarray],
    vmax: float,
    keep: np.ndarray,
    margin: float = 0.4,
) -> tuple[float, float, float, float]:
    """The part of the floor a top-down map of the report shows, as (x min, x max, y min,
    y max) in the base frame: :func:`momakitchen.perception.figures.focus_region`, where
    any of ``maps`` exceeds 10 % of ``vmax`` and the points ``keep`` ((K, 2): the target,
    the chosen poses), with ``margin`` around them, within the visible floor."""
    from momakitchen.perception.figures import focus_region

    return focus_region(floor_xyz, maps, vmax, keep, margin)


def _mark_target(ax: Any, mask: np.ndarray) -> None:
    """Outline the target's pixels in an image panel and label them."""
    if not mask.any():
        return
    ax.contour(mask.astype(float), levels=[0.5], colors="red", linewidths=1.8)
    rows, cols = np.nonzero(mask)
    ax.annotate(
        "target",
        (float(cols.mean()), float(rows.min())),
        xytext=(0, 8),
        textcoords="offset points",
        ha="center",
        color="red",
        fontsize=9,
        weight="bold",
    )


def _legend_marks(ax: Any, region: tuple[float, float, float, float]) -> None:
    """A legend for the marks of the top-down maps: the target star, the robot's camera
    (only when the map's ``region``, (x min, x max, y min, y max) in the base frame, shows
    the robot at the origin: the maps are cropped around the target) and the base poses."""
    from matplotlib.lines import Line2D

    x0, x1, y0, y1 = region
    camera = [Line2D([], [], marker="^", ls="", color="black", ms=8, label="robot (camera)")]
    handles = [
        Line2D([], [], marker="*", ls="", color="red", mec="black", ms=12, label="target"),
        *(camera if x0 <= 0.0 <= x1 and y0 <= 0.0 <= y1 else []),
        Line2D([], [], marker=r"$\rightarrow$", ls="", color="red", ms=12, label="chosen pose"),
        Line2D([], [], marker=r"$\rightarrow$", ls="", color="orange", ms=12, label="Top-2..5"),
    ]
    ax.legend(handles=handles, loc="lower left", fontsize=8, framealpha=0.85)


def report_figure(
    rgb: np.ndarray,
    depth: np.ndarray,
    target_mask: np.ndarray,
    intrinsics: Any,
    camera_to_base: np.ndarray,
    pred: Any,
    gt: np.ndarray,
    outcome: str,
    result: dict[str, Any],
) -> bytes:
    """The demo's report: what the robot sees (the target outlined), what the model
    predicts, where the robot went, what happened, and the ground truth from the grid of
    trials. The predicted and true maps share one colour scale and show the same region
    around the target."""
    import textwrap

    from momakitchen.perception.figures import (
        DOC_WIDTH,
        floor_map,
        image_overlay,
        png_bytes,
        pyplot,
        text_sizes,
    )

    plt = pyplot()
    with plt.rc_context(text_sizes(8)):
        fig, axes = plt.subplots(2, 3, figsize=(DOC_WIDTH, 6.4), layout="constrained", dpi=110)
        fig.suptitle(
            f"Where should the {result['robot']} stop to manipulate the {result['target']}?"
            f"\n(scene {result['scene_id']}, model {result['model']})",
            fontsize=10,
        )
        axes[0, 0].imshow(rgb)
        _mark_target(axes[0, 0], target_mask)
        axes[0, 0].set_title(f"1. first-person RGB\n(target: {result['target']})")
        axes[0, 0].axis("off")
        im = axes[0, 1].imshow(np.where(depth > 0, depth, np.nan), cmap="turbo")
        axes[0, 1].set_title("2. depth, back-projected\nto a point cloud")
        axes[0, 1].axis("off")
        fig.colorbar(im, ax=axes[0, 1], shrink=0.75, label="depth (m)")
        # One scale for every affordance panel: the model is trained to predict the success
        # rate the ground truth holds, so the two maps are read against each other.
        vmax = max(float(pred.affordance.max()), float(np.max(gt, initial=0.0)), 0.05)
        image_overlay(
            axes[0, 2],
            rgb,
            pred.floor_xyz,
            pred.affordance / vmax,
            intrinsics,
            camera_to_base,
            "3. predicted affordance on the\nfloor (circle 1: the stop)",
            pred.poses,
        )
        _mark_target(axes[0, 2], target_mask)
        region = report_region(
            pred.floor_xyz,
            [pred.affordance, gt],
            vmax,
            np.concatenate([np.asarray(pred.target_xyz, float)[None, :2], pred.poses[:, :2]]),
        )
        sc = floor_map(
            axes[1, 0],
            pred.floor_xyz,
            pred.affordance,
            "4. predicted map, top-down\n(arrows: Top-5 poses)",
            pred.target_xyz,
            pred.poses,
            vmax=vmax,
            extent=region,
        )
        floor_map(
            axes[1, 1],
            pred.floor_xyz,
            gt,
            f"5. ground truth, {result['grid']['trials']} physics trials\n"
            f"({result['grid']['successes']} succeeded); chosen pose: {outcome}",
            pred.target_xyz,
            pred.poses[:1],
            vmax=vmax,
            extent=region,
        )
        fig.colorbar(
            sc, ax=[axes[1, 0], axes[1, 1]], shrink=0.8, label="affordance = success rate (4, 5)"
        )
        _legend_marks(axes[1, 0], region)
        ax = axes[1, 2]
        ax.axis("off")
        x, y, yaw = result["chosen_pose_base_frame"]
        lines = [
            "6. result",
            "",
            "chosen base pose (robot frame):",
            f"  x = {x:.2f} m, y = {y:.2f} m, yaw = {np.degrees(yaw):.0f}°",
            f"predicted affordance there: {result['predicted_affordance']:.2f}",
            f"  (uncertainty {result['uncertainty']:.3f})",
            f"ground truth there: {result['ground_truth_at_pose']:.2f}",
            f"trial executed in PyBullet: {outcome}",
            "",
            *textwrap.wrap(
                "How to read this: the model sees only the RGB-D view (1, 2; target outlined "
                "in red) and scores every visible floor point for how well the robot could "
                "manipulate the target from there (3, 4). The robot drives to the best point, "
                "facing the target, and tries. The ground truth (5) comes from really trying "
                "from every point of a 10 cm grid in simulation. 4 and 5 show the floor "
                "around the target on one colour scale.",
                36,
            ),
        ]
        ax.text(
            0.0,
            1.0,
            "\n".join(lines),
            va="top",
            ha="left",
            transform=ax.transAxes,
            bbox={
                "facecolor": "#e8f5e9" if result["trial"]["success"] else "#ffebee",
                "edgecolor": "none",
                "pad": 6,
            },
        )
        return png_bytes(fig)
