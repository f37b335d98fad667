"""Figures of predictions: the map over the camera image and top-down in the base frame."""

from __future__ import annotations

import io
from typing import Any

import numpy as np


def pyplot():
    """matplotlib.pyplot on the Agg backend (figures are written to files, never shown)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


# The width (inches) at which the documentation shows a figure: 860 pixels at 100 dpi, the
# width of a page's text column. A figure this wide keeps its point sizes there; every
# text of a figure the documents show is at least MIN_POINTS large at that width.
DOC_WIDTH = 8.6
MIN_POINTS = 8.0


def text_sizes(points: float = MIN_POINTS) -> dict[str, float]:
    """matplotlib settings that set every text of a figure (titles, labels, ticks,
    legends) to ``points`` (for ``pyplot().rc_context``)."""
    keys = ["font.size", "axes.titlesize", "axes.labelsize", "xtick.labelsize"]
    keys += ["ytick.labelsize", "legend.fontsize", "legend.title_fontsize", "figure.titlesize"]
    return dict.fromkeys(keys, points)


def png_bytes(fig: Any, dpi: float = 100) -> bytes:
    """The figure as PNG bytes (closed afterwards)."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, metadata={"Software": None})
    pyplot().close(fig)
    return buf.getvalue()


def image_overlay(
    ax: Any,
    rgb: np.ndarray,
    xyz: np.ndarray,
    values: np.ndarray,
    intrinsics: Any,
    camera_to_base: np.ndarray,
    title: str,
    poses: np.ndarray | None = None,
) -> None:
    """The camera image with floor points coloured by ``values`` (viridis, 0..1) and the
    chosen base positions (numbered, best first). Shapes: ``xyz`` (N, 3), ``values`` (N,)."""
    from momakitchen.frames import transform
    from momakitchen.perception.camera import project

    ax.imshow(rgb)
    to_cam = np.linalg.inv(camera_to_base)
    cam = transform(to_cam, xyz)
    uv = project(cam, intrinsics)
    ax.scatter(
        uv[:, 0], uv[:, 1], c=values, cmap="viridis", vmin=0, vmax=1, s=4, alpha=0.55, linewidths=0
    )
    if poses is not None and len(poses):
        pts = np.column_stack([poses[:, :2], np.zeros(len(poses))])
        puv = project(transform(to_cam, pts), intrinsics)
        for i, (u, v) in enumerate(puv):
            ax.plot(
                u,
                v,
                marker="o",
                ms=11 if i == 0 else 7,
                mfc="none",
                mec="red" if i == 0 else "orange",
                mew=2,
            )
            ax.annotate(
                str(i + 1),
                (u, v),
                xytext=(6, -6),
                textcoords="offset points",
                color="white",
                fontsize=8,
                weight="bold",
            )
    ax.set_xlim(0, rgb.shape[1])
    ax.set_ylim(rgb.shape[0], 0)
    ax.set_title(title, fontsize=10)
    ax.axis("off")


def floor_map(
    ax: Any,
    xyz: np.ndarray,
    values: np.ndarray,
    title: str,
    target: np.ndarray | None = None,
    poses: np.ndarray | None = None,
    cmap: str = "viridis",
    vmax: float = 1.0,
    extent: tuple[float, float, float, float] | None = None,
) -> Any:
    """Top-down view of the floor in the robot base frame (forward up, left to the left):
    points coloured by ``values`` (0..``vmax``), the robot at the origin, the target (star)
    and the chosen poses as arrows facing the target. ``extent`` = (x min, x max, y min,
    y max) in the base frame crops the view to a region. Returns the scatter (for a colour
    bar)."""
    from matplotlib.ticker import FuncFormatter

    sc = ax.scatter(
        -xyz[:, 1], xyz[:, 0], c=values, cmap=cmap, vmin=0, vmax=vmax, s=6, linewidths=0
    )
    ax.plot(0, 0, marker="^", color="black", ms=9)
    ax.annotate("camera", (0, 0), xytext=(6, -10), textcoords="offset points", fontsize=7)
    if target is not None:
        ax.plot(-target[1], target[0], marker="*", color="red", ms=15, mec="black")
    if poses is not None:
        for i, (x, y, yaw) in enumerate(poses):
            color = "red" if i == 0 else "orange"
            ax.arrow(
                -y,
                x,
                -0.18 * np.sin(yaw),
                0.18 * np.cos(yaw),
                width=0.025 if i == 0 else 0.015,
                color=color,
                length_includes_head=True,
                zorder=5,
            )
            ax.annotate(
                str(i + 1),
                (-y, x),
                xytext=(-10, 4),
                textcoords="offset points",
                fontsize=8,
                color=color,
                weight="bold",
            )
    ax.set_aspect("equal")
    if extent is not None:
        x0, x1, y0, y1 = extent
        ax.set_xlim(-y1, -y0)
        ax.set_ylim(x0, x1)
    ax.set_xlabel("y (m), positive to the left", fontsize=8)
    ax.set_ylabel("x, forward (m)", fontsize=8)
    # The horizontal axis is -y (left on the left): label it with y. A formatter keeps the
    # view limits (fixing the ticks would widen them to the ticks' range).
    ax.xaxis.set_major_formatter(FuncFormatter(lambda t, _pos: f"{-t + 0.0:g}"))
    ax.set_title(title, fontsize=10)
    return sc


def prediction_figure(
    pred: Any,
    rgb: np.ndarray | None,
    depth: np.ndarray | None,
    intrinsics: Any,
    camera_to_base: np.ndarray | None,
) -> bytes:
    """PNG: the map over the image (when an image is given), top-down map, uncertainty;
    the floor correction applied to the frame and any warning as the title."""
    plt = pyplot()
    with_image = rgb is not None and intrinsics is not None and camera_to_base is not None
    correction = getattr(pred, "correction", None)
    if with_image and correction is not None:
        # the map lives in the corrected frame: project it through the corrected camera
        camera_to_base = correction.matrix @ np.asarray(camera_to_base, np.float64)
    n = 3 if with_image else 2
    fig, axes = plt.subplots(1, n, figsize=(5.2 * n, 4.6), constrained_layout=True)
    i = 0
    if with_image:
        assert rgb is not None and camera_to_base is not None  # implied by with_image
        image_overlay(
            axes[0],
            rgb,
            pred.floor_xyz,
            pred.affordance,
            intrinsics,
            camera_to_base,
            "affordance over the image (1 = best pose)",
            pred.poses,
        )
        i = 1
    sc = floor_map(
        axes[i],
        pred.floor_xyz,
        pred.affordance,
        f"affordance ({pred.model}, robot {pred.robot})",
        pred.target_xyz,
        pred.poses,
        vmax=max(float(pred.affordance.max()), 0.05),
    )
    fig.colorbar(sc, ax=axes[i], shrink=0.8, label="affordance")
    vmax = max(float(pred.uncertainty.max()), 1e-3)
    sc = floor_map(
        axes[i + 1],
        pred.floor_xyz,
        pred.uncertainty,
        "uncertainty (MC-dropout std)",
        pred.target_xyz,
        pred.poses[:1],
        cmap="magma",
        vmax=vmax,
    )
    fig.colorbar(sc, ax=axes[i + 1], shrink=0.8, label="std")
    lines = []
    if correction is not None:
        c = correction
        lines.append(
            f"floor correction: camera {c.height * 100:+.1f} cm, pitch {c.pitch:+.2f} deg, "
            f"roll {c.roll:+.2f} deg, depth scale {c.scale:.3f} "
            f"({c.inliers} floor points, residual {c.residual * 1000:.1f} mm); "
            f"target {float(np.hypot(*pred.target_xyz[:2])):.2f} m away"
        )
    lines += [f"warning: {w}" for w in getattr(pred, "warnings", ())]
    if lines:
        fig.suptitle("\n".join(lines), fontsize=9)
    return png_bytes(fig)
