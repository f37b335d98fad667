"""Picture of a configuration's labels: trial outcomes by stage next to the dense map, at
the width a page shows it (DOC_WIDTH)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.artist import Artist
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from momakitchen.robots import get_robot_spec
from momakitchen.scene.configuration import Configuration
from momakitchen.scene.geometry import box_corners, corners_of, overlap_matrix
from momakitchen.scene.layout import Layout
from momakitchen.scene.overview import (
    DOC_WIDTH,
    DPI,
    categories,
    category_handles,
    draw_kitchen,
    draw_target,
    frame_plan,
    name_units,
    target_handle,
    text_sizes,
)
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
# The floor the dense map's mask sets to 0.
MASKED = (1.0, 0.55, 0.1)


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
    """Write a two-panel PNG, DOC_WIDTH wide: outcome/stage per grid position, and the
    dense map with the footprint mask (0 where the base does not fit, as the dataset stores
    it), one legend for both below them."""
    import matplotlib

    reach = get_robot_spec(labels.robot).reach
    ax_, ay_ = labels.anchor[:2]
    xlim = (ax_ - reach - 0.45, ax_ + reach + 0.45)
    ylim = (max(-0.1, ay_ - 0.6), ay_ + reach + 0.45)
    cfg_d = dense or DenseMapConfig()

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

    counts = labels.stage_counts()
    handles: list[Artist] = [
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
    ]
    handles.append(target_handle(cfg))
    if masked.any():
        label = "0 by the mask: the base\ndoes not fit, or beyond reach"
        handles.append(Patch(facecolor=MASKED, edgecolor="k", label=label))
    handles += category_handles(categories(layout, cfg, xlim, ylim))

    # Laid out in inches: the panels as large as their content (equal aspect), the colour
    # bar to their right, the legend below.
    left, gap, bar, bar_gap, right = 0.65, 0.2, 0.15, 0.15, 0.6
    panel_w = (DOC_WIDTH - left - gap - bar_gap - bar - right) / 2
    panel_h = panel_w * (ylim[1] - ylim[0]) / (xlim[1] - xlim[0])
    ncols = 4
    key_h = 0.1 + 0.21 * (-(-len(handles) // ncols) + 1)
    title, below = 0.45, 0.5
    height = 0.05 + title + panel_h + below + key_h
    bottom = key_h + below
    with matplotlib.rc_context(text_sizes()):
        # A bare Figure (no pyplot): no global state, no display backend needed.
        fig = Figure(figsize=(DOC_WIDTH, height), dpi=DPI)

        def place(x: float, w: float):
            return fig.add_axes((x / DOC_WIDTH, bottom / height, w / DOC_WIDTH, panel_h / height))

        ax1 = place(left, panel_w)
        ax2 = place(left + panel_w + gap, panel_w)
        cax = place(left + 2 * panel_w + gap + bar_gap, bar)
        cax.set_label("<colorbar>")  # as matplotlib names the colour bars it places

        names1 = draw_kitchen(ax1, layout, cfg, handles=False)
        for stage in Stage:
            sel = labels.stages == stage
            if sel.any():
                ax1.scatter(
                    labels.positions[sel, 0],
                    labels.positions[sel, 1],
                    s=18,
                    color=STAGE_COLOURS[stage],
                    edgecolors="k",
                    linewidths=0.3,
                    zorder=4,
                )
        draw_target(ax1, cfg)
        frame_plan(ax1, xlim, ylim)
        ax1.set_title(
            f"trials: {labels.robot} at the {labels.target},\n"
            f"{int(labels.outcomes.sum())}/{len(labels.stages)} succeeded"
        )

        names2 = draw_kitchen(ax2, layout, cfg, handles=False, alpha=0.5)
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
        overlay[masked] = (*MASKED, 0.8)
        ax2.imshow(
            overlay, origin="lower", extent=(*xlim, *ylim), interpolation="nearest", zorder=3
        )
        draw_target(ax2, cfg)
        frame_plan(ax2, xlim, ylim)
        ax2.tick_params(labelleft=False)  # the same y as the trials' panel
        ax2.set_title(
            f"dense affordance map\n(theta={cfg_d.theta} m, k={cfg_d.k}, sigma={cfg_d.sigma} m)"
        )
        fig.colorbar(im, cax=cax, label="affordance (dense map)")
        # One label of y for both panels, beside the first.
        ylabel = ax1.get_ylabel()
        ax1.set_ylabel("")
        ax2.set_ylabel("")
        fig.supylabel(ylabel, x=0.1 / DOC_WIDTH, ha="left", y=(bottom + panel_h / 2) / height)
        fig.legend(
            handles=handles,
            loc="upper center",
            bbox_to_anchor=(0.5, key_h / height),
            ncols=ncols,
            frameon=False,
        )
        fig.draw_without_rendering()
        name_units(ax1, names1)
        name_units(ax2, names2)
        fig.savefig(path, dpi="figure")
