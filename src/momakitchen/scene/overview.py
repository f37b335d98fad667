"""Overview figure of a kitchen: a rendered view and an annotated top-down plan."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.artist import Artist
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch, Polygon, Wedge

from momakitchen.assets import get_category
from momakitchen.robots import get_robot_spec
from momakitchen.scene.configuration import Configuration, Scene, handle_anchor
from momakitchen.scene.geometry import semicircle_grid
from momakitchen.scene.layout import Layout

# Display colour of each category in plans (one place, shared by every figure).
PLAN_COLOURS = {
    "cabinet": "#c8a165",
    "sink": "#8fb3c9",
    "dishwasher": "#a9a9a9",
    "oven": "#5a5a5a",
    "fridge": "#dfe6ea",
    "microwave": "#3d3d3d",
    "bottle": "#2e8b57",
    "pot": "#b0413e",
    "fruit": "#e07b00",
    "medicine_bottle": "#f2c94c",
    "vegetable": "#6aa84f",
    "chair": "#7b4f9d",
    "trolley": "#9d4f7b",
    "bin": "#4f6d9d",
    "table": "#8c6d46",
    "cart": "#c05780",
}


def _poly(ax, footprint, colour, **kw) -> None:
    ax.add_patch(
        Polygon(
            footprint.corners(), closed=True, facecolor=colour, edgecolor="k", linewidth=0.8, **kw
        )
    )


def draw_kitchen(
    ax, layout: Layout, cfg: Configuration, *, handles: bool = True, alpha: float = 0.95
) -> None:
    """Room, furniture (with handles), objects on the counter and obstacles, top down."""
    room = layout.room
    outline: list[list[float]] = [
        [0, 0],
        [room.width, 0],
        [room.width, room.depth],
        [0, room.depth],
    ]
    ax.add_patch(
        Polygon(outline, closed=True, facecolor="#f4efe6", edgecolor="k", linewidth=2, zorder=0)
    )
    for unit in layout.furniture:
        fp = unit.footprint()
        _poly(ax, fp, PLAN_COLOURS.get(unit.category, "#cccccc"), alpha=alpha)
        # Base units are labelled near their front edge, so appliances on top stay readable.
        on_floor = get_category(unit.category).kind == "furniture"
        ty = fp.y + fp.width / 2 - 0.12 if on_floor else fp.y
        ax.text(
            fp.x,
            ty,
            unit.category,
            ha="center",
            va="center",
            fontsize=6.5,
            clip_on=True,
            color="white" if unit.category in ("oven", "microwave") else "black",
        )
        if handles:
            for i in range(len(unit.model.articulations)):
                hx, hy, _ = handle_anchor(unit, i)
                ax.plot(hx, hy, marker="s", ms=3, color="k")
    for obj in cfg.objects:
        _poly(ax, obj.footprint(), PLAN_COLOURS.get(obj.category, "#999999"))
    for ob in cfg.obstacles:
        _poly(ax, ob.footprint(), PLAN_COLOURS.get(ob.category, "#999999"), alpha=0.9 * alpha)
        ax.text(
            ob.x,
            ob.y,
            ob.category,
            ha="center",
            va="center",
            fontsize=6,
            color="white",
            clip_on=True,
        )


def frame_plan(ax, xlim: tuple[float, float], ylim: tuple[float, float]) -> None:
    """Axes seen from the room towards the wall (wall at the top), like the rendered view."""
    ax.set_xlim(max(xlim), min(xlim))
    ax.set_ylim(max(ylim), min(ylim))
    ax.set_aspect("equal")
    ax.set_xlabel("x (m, along the wall)")
    ax.set_ylabel("y (m, into the room)")


def draw_target(ax, cfg: Configuration) -> None:
    tx, ty, _ = cfg.target.anchor
    ax.plot(tx, ty, marker="*", ms=16, color="red", markeredgecolor="k", zorder=5)


def draw_plan(ax, scene: Scene, cfg: Configuration) -> None:
    """Top-down plan: furniture, handles, objects, the target, its semicircle, obstacles."""
    room = scene.layout.room
    draw_kitchen(ax, scene.layout, cfg)
    robot = get_robot_spec(cfg.robot)
    tx, ty, _ = cfg.target.anchor
    ax.add_patch(
        Wedge(
            (tx, ty),
            robot.reach,
            0,
            180,
            facecolor="#3b82f6",
            alpha=0.12,
            edgecolor="#1d4ed8",
            linewidth=1.2,
        )
    )
    grid = semicircle_grid((tx, ty), robot.reach, scene.config.grid_spacing)
    ax.scatter(grid[:, 0], grid[:, 1], s=2, color="#1d4ed8", alpha=0.5, linewidths=0)
    draw_target(ax, cfg)
    frame_plan(ax, (-0.2, room.width + 0.2), (-0.2, room.depth + 0.2))


def plan_legend(ax, scene: Scene, cfg: Configuration) -> None:
    present = {u.category for u in scene.layout.furniture}
    present |= {o.category for o in (*cfg.objects, *cfg.obstacles)}
    handles: list[Artist] = [
        Patch(facecolor=PLAN_COLOURS.get(c, "#ccc"), edgecolor="k", label=c)
        for c in sorted(present, key=lambda c: (get_category(c).kind, c))
    ]
    handles += [
        Line2D(
            [],
            [],
            marker="*",
            ls="",
            ms=12,
            color="red",
            markeredgecolor="k",
            label=f"target: {cfg.target.category}",
        ),
        Line2D([], [], marker="s", ls="", ms=4, color="k", label="handle / lever"),
        Patch(
            facecolor="#3b82f6",
            alpha=0.25,
            edgecolor="#1d4ed8",
            label=f"sampling semicircle ({cfg.robot}, r={get_robot_spec(cfg.robot).reach} m)",
        ),
    ]
    ax.legend(
        handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, frameon=False
    )


def save_overview(scene: Scene, config_index: int, view_rgb: np.ndarray | None, path: Path) -> None:
    """Write the overview PNG: rendered view (if given) and the plan of one configuration."""
    cfg = scene.configurations[config_index]
    ncols = 2 if view_rgb is not None else 1
    # A bare Figure (no pyplot): no global state, no display backend needed.
    fig = Figure(figsize=(7.5 * ncols, 6.2))
    axes = fig.subplots(1, ncols, squeeze=False)
    if view_rgb is not None:
        axes[0, 0].imshow(view_rgb)
        axes[0, 0].set_title(f"scene {scene.layout.scene_id}: rendered view")
        axes[0, 0].axis("off")
    ax = axes[0, -1]
    draw_plan(ax, scene, cfg)
    plan_legend(ax, scene, cfg)
    ax.set_title(f"top-down plan, configuration {config_index} (robot {cfg.robot})")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
