"""Picture of a configuration's labels: trial outcomes by stage next to the dense map."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from momakitchen.robots import get_robot_spec
from momakitchen.scene.configuration import Configuration
from momakitchen.scene.geometry import box_corners, corners_of, overlap_matrix
from momakitchen.scene.layout import Layout
from momakitchen.scene.overview import draw_kitchen, draw_target, frame_plan
from momakitchen.sim.config import STAGE_NAMES, DenseMapConfig, Stage
from momakitchen.sim.labels import Labels, dense_map, standable

STAGE_COLOURS = {
    Stage.SUCCESS: "#16a34a",
    Stage.BASE_COLLISION: "#6b7280",
    Stage.OUT_OF_REACH: "#d1d5db",
    Stage.IK_FAILED: "#f59e0b",
    Stage.ARM_COLLISION: "#9333ea",
    Stage.EXECUTION_FAILED: "#dc2626",
}


def floor_raster(
    layout: Layout, cfg: Configuration, xlim, ylim, step: float = 0.02
) -> tuple[np.ndarray, np.ndarray]:
    """Free floor points on a raster: (H, W, 2) coordinates and (H, W) bool mask of points
    not under furniture or obstacles."""
    xs = np.arange(xlim[0], xlim[1], step) + step / 2
    ys = np.arange(ylim[0], ylim[1], step) + step / 2
    gx, gy = np.meshgrid(xs, ys)
    pts = np.stack([gx, gy], axis=-1)
    flat = pts.reshape(-1, 2)
    cells = box_corners(flat[:, 0], flat[:, 1], 0.0, 1e-3, 1e-3)
    occupied = corners_of(layout.footprints() + [o.footprint() for o in cfg.obstacles])
    free = ~overlap_matrix(cells, occupied).any(1)
    free &= (flat[:, 0] > 0) & (flat[:, 0] < layout.room.width) & (flat[:, 1] > 0)
    free &= flat[:, 1] < layout.room.depth
    return pts, free.reshape(gx.shape)


def save_label_figure(
    layout: Layout,
    cfg: Configuration,
    labels: Labels,
    path: Path,
    dense: DenseMapConfig | None = None,
) -> None:
    """Write a two-panel PNG: outcome/stage per grid position, and the dense map with
    the footprint mask (0 where the base does not fit, as the dataset stores it)."""
    reach = get_robot_spec(labels.robot).reach
    ax_, ay_ = labels.anchor[:2]
    xlim = (ax_ - reach - 0.45, ax_ + reach + 0.45)
    ylim = (max(-0.1, ay_ - 0.6), ay_ + reach + 0.45)
    fig = Figure(figsize=(13, 6.2))
    ax1, ax2 = fig.subplots(1, 2)
    draw_kitchen(ax1, layout, cfg, handles=False)
    counts = labels.stage_counts()
    for stage in Stage:
        sel = labels.stages == stage
        if sel.any():
            ax1.scatter(
                labels.positions[sel, 0],
                labels.positions[sel, 1],
                s=22,
                color=STAGE_COLOURS[stage],
                edgecolors="k",
                linewidths=0.3,
                zorder=4,
            )
    draw_target(ax1, cfg)
    frame_plan(ax1, xlim, ylim)
    ax1.legend(
        handles=[
            Line2D(
                [],
                [],
                marker="o",
                ls="",
                color=STAGE_COLOURS[s],
                markeredgecolor="k",
                label=f"{name.replace('_', ' ')} ({counts[name]})",
            )
            for s, name in zip(Stage, STAGE_NAMES, strict=True)
        ],
        loc="lower left",
        fontsize=7,
        framealpha=0.9,
    )
    ax1.set_title(
        f"trials: {labels.robot}, target {labels.target}, "
        f"{int(labels.outcomes.sum())}/{len(labels.stages)} succeeded"
    )

    pts, free = floor_raster(layout, cfg, xlim, ylim)
    values = dense_map(labels.positions, labels.outcomes, pts.reshape(-1, 2), dense)
    # The mask, as in the dataset's maps: 0 where the base, facing the target, would not
    # fit or outside the sampling area; drawn apart where it removes interpolated affordance.
    fits = standable(layout, cfg, pts.reshape(-1, 2)).reshape(free.shape)
    values = values.reshape(free.shape)
    image = np.where(free, np.where(fits, values, 0.0), np.nan)
    # Orange: all floor the mask sets to 0, so that a 0 of the trials (dark) and a 0 of
    # the mask (the base does not fit there, or it lies beyond reach) look different.
    masked = free & ~fits
    draw_kitchen(ax2, layout, cfg, handles=False, alpha=0.5)
    im = ax2.imshow(
        image,
        origin="lower",
        extent=(*xlim, *ylim),
        cmap="viridis",
        vmin=0,
        vmax=1,
        interpolation="nearest",
        zorder=3,
    )
    overlay = np.zeros((*masked.shape, 4))
    overlay[masked] = (1.0, 0.55, 0.1, 0.8)
    ax2.imshow(overlay, origin="lower", extent=(*xlim, *ylim), interpolation="nearest", zorder=3)
    draw_target(ax2, cfg)
    frame_plan(ax2, xlim, ylim)
    if masked.any():
        ax2.legend(
            handles=[Patch(color=(1.0, 0.55, 0.1), label="0: base does not fit, or beyond reach")],
            loc="lower left",
            fontsize=7,
            framealpha=0.9,
        )
    cfg_d = dense or DenseMapConfig()
    ax2.set_title(
        f"dense affordance map (theta={cfg_d.theta} m, k={cfg_d.k}, sigma={cfg_d.sigma} m)"
    )
    fig.colorbar(im, ax=ax2, fraction=0.046, pad=0.04, label="affordance")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
