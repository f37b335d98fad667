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


def png_bytes(fig: Any) -> bytes:
    """The figure as PNG bytes at its own dpi (100 unless made with another), closed
    afterwards."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi="figure", metadata={"Software": None})
    pyplot().close(fig)
    return buf.getvalue()


# The colours of the chosen poses: the best one, and the rest of the Top-k.
BEST, OTHERS = "red", "darkorange"


def _number(
    ax: Any, text: str, xy: tuple[float, float], offset: tuple[float, float], colour: str
) -> None:
    """A pose's rank beside it: bold, outlined in white so that it reads on any colour."""
    from matplotlib import patheffects

    ax.annotate(
        text,
        xy,
        xytext=offset,
        textcoords="offset points",
        ha="center",
        va="center",
        fontsize=MIN_POINTS + 1,
        weight="bold",
        color=colour,
        path_effects=[patheffects.withStroke(linewidth=2.5, foreground="white")],
        zorder=6,
    )


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
    chosen base positions (circles, the best one numbered 1). Shapes: ``xyz`` (N, 3),
    ``values`` (N,)."""
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
        for i, (u, v) in reversed(list(enumerate(puv))):  # the best one on top
            colour = BEST if i == 0 else OTHERS
            ax.plot(u, v, marker="o", ms=11 if i == 0 else 8, mfc="none", mec=colour, mew=2)
        # Only the best is numbered: the poses lie close together seen from the camera.
        _number(ax, "1", tuple(puv[0]), (0, 13), BEST)
    ax.set_xlim(0, rgb.shape[1])
    ax.set_ylim(rgb.shape[0], 0)
    ax.set_title(title)
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
    points coloured by ``values`` (0..``vmax``), the robot's camera at the origin (a
    triangle), the target (star) and the chosen poses as arrows facing the target,
    numbered best first (:func:`marks_legend` explains them). ``extent`` = (x min, x max,
    y min, y max) in the base frame crops the view to a region. Returns the scatter (for a
    colour bar)."""
    from matplotlib.ticker import FuncFormatter

    sc = ax.scatter(
        -xyz[:, 1], xyz[:, 0], c=values, cmap=cmap, vmin=0, vmax=vmax, s=6, linewidths=0
    )
    ax.plot(0, 0, marker="^", color="black", ms=9)
    if target is not None:
        ax.plot(-target[1], target[0], marker="*", color="red", ms=15, mec="black", zorder=6)
    if poses is not None:
        for i, (x, y, yaw) in reversed(list(enumerate(poses))):  # the best one on top
            colour = BEST if i == 0 else OTHERS
            dx, dy = -np.sin(yaw), np.cos(yaw)  # the heading, on the page
            ax.arrow(
                -y,
                x,
                0.18 * dx,
                0.18 * dy,
                width=0.025 if i == 0 else 0.015,
                color=colour,
                length_includes_head=True,
                zorder=5,
            )
            # The rank behind the arrow's tail, clear of its head.
            _number(ax, str(i + 1), (-y, x), (-10 * dx, -10 * dy), colour)
    ax.set_aspect("equal")
    if extent is not None:
        x0, x1, y0, y1 = extent
        ax.set_xlim(-y1, -y0)
        ax.set_ylim(x0, x1)
    ax.set_xlabel("y (m), positive to the left")
    ax.set_ylabel("x, forward (m)")
    # The horizontal axis is -y (left on the left): label it with y. A formatter keeps the
    # view limits (fixing the ticks would widen them to the ticks' range).
    ax.xaxis.set_major_formatter(FuncFormatter(lambda t, _pos: f"{-t + 0.0:g}"))
    ax.set_title(title)
    return sc


def marks_legend(
    ax: Any,
    camera: bool = True,
    poses: int = 0,
    image: bool = False,
    floor: str = "",
    **kwargs: Any,
) -> Any:
    """A legend of :func:`floor_map`'s (and :func:`image_overlay`'s) marks: the target,
    the robot's camera (``camera``: where a map shows it), the chosen poses (``poses``:
    how many; arrows, or with ``image`` arrows and circles), and ``floor``, the label of
    the floor points' colour (none: left out). ``kwargs`` go to ``legend``."""
    from matplotlib.lines import Line2D

    def mark(marker: str, label: str, **kw: Any) -> Line2D:
        return Line2D([], [], marker=marker, ls="", label=label, **kw)

    where = " (arrow; circle on the image)" if image else "\n(arrow, facing the target)"
    handles = [mark("*", "target", color="red", mec="black", ms=12)]
    if camera:
        handles.append(mark("^", "robot's camera (the base frame's origin)", color="black", ms=8))
    if poses:
        handles.append(mark(r"$\rightarrow$", "1: the best base pose" + where, color=BEST, ms=12))
    if poses > 1:
        label = f"2–{poses}: the next poses" if poses > 2 else "2: the next pose"
        handles.append(mark(r"$\rightarrow$", label, color=OTHERS, ms=12))
    if floor:
        handles.append(mark("o", floor, color=(0.13, 0.57, 0.55), ms=5))
    return ax.legend(handles=handles, **kwargs)


def focus_region(
    floor_xyz: np.ndarray,
    maps: list[np.ndarray],
    vmax: float,
    keep: np.ndarray,
    margin: float = 0.4,
) -> tuple[float, float, float, float]:
    """The part of the floor a cropped top-down map shows, as (x min, x max, y min, y max)
    in the base frame: where any of ``maps`` exceeds 10 % of ``vmax``, and the points
    ``keep`` ((K, 2): the target, the chosen poses), with ``margin`` around them, within
    the visible floor. The rest of the view is floor nobody should stand on."""
    xy = floor_xyz[:, :2]
    hot = np.zeros(len(xy), bool)
    for m in maps:
        hot |= np.asarray(m) > 0.1 * vmax
    keep = np.asarray(keep, float).reshape(-1, 2)
    pts = np.concatenate([xy[hot], keep])
    lo, hi = pts.min(0) - margin, pts.max(0) + margin
    if len(xy):  # never beyond the floor that is seen (plus the margin)...
        lo = np.maximum(lo, xy.min(0) - margin)
        hi = np.minimum(hi, xy.max(0) + margin)
    if len(keep):  # ...but always the target and the chosen poses
        lo = np.minimum(lo, keep.min(0) - margin)
        hi = np.maximum(hi, keep.max(0) + margin)
    return float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])


def prediction_figure(
    pred: Any,
    rgb: np.ndarray | None,
    depth: np.ndarray | None,
    intrinsics: Any,
    camera_to_base: np.ndarray | None,
) -> bytes:
    """PNG, DOC_WIDTH wide: the map over the image (when an image is given; else the whole
    visible floor from above), the map and its uncertainty from above around the target
    and the Top-k poses, numbered, and a panel with the legend, the best pose, the floor
    correction applied to the frame and any warning."""
    import textwrap

    plt = pyplot()
    with_image = rgb is not None and intrinsics is not None and camera_to_base is not None
    correction = getattr(pred, "correction", None)
    if with_image and correction is not None:
        # the map lives in the corrected frame: project it through the corrected camera
        camera_to_base = correction.matrix @ np.asarray(camera_to_base, np.float64)
    k = len(pred.poses)
    vmax = max(float(pred.affordance.max()), 0.05)
    keep = np.concatenate([np.asarray(pred.target_xyz, float)[None, :2], pred.poses[:, :2]])
    region = focus_region(pred.floor_xyz, [pred.affordance], vmax, keep, margin=0.5)
    with plt.rc_context(text_sizes(MIN_POINTS)):
        fig, axes = plt.subplots(2, 2, figsize=(DOC_WIDTH, 7.6), layout="constrained", dpi=120)
        if with_image:
            assert rgb is not None and camera_to_base is not None  # implied by with_image
            image_overlay(
                axes[0, 0],
                rgb,
                pred.floor_xyz,
                pred.affordance / vmax,
                intrinsics,
                camera_to_base,
                f"affordance over the image, Top-{k} circled",
                pred.poses,
            )
        else:
            floor_map(
                axes[0, 0],
                pred.floor_xyz,
                pred.affordance,
                "affordance, the whole visible floor",
                pred.target_xyz,
                pred.poses[:1],
                vmax=vmax,
            )
        sc = floor_map(
            axes[0, 1],
            pred.floor_xyz,
            pred.affordance,
            f"affordance around the target, Top-{k}",
            pred.target_xyz,
            pred.poses,
            vmax=vmax,
            extent=region,
        )
        fig.colorbar(sc, ax=axes[0, 1], shrink=0.9, label="affordance (success rate)")
        sc = floor_map(
            axes[1, 0],
            pred.floor_xyz,
            pred.uncertainty,
            "uncertainty (MC-dropout std)",
            pred.target_xyz,
            pred.poses[:1],
            cmap="magma",
            vmax=max(float(pred.uncertainty.max()), 1e-3),
            extent=region,
        )
        fig.colorbar(sc, ax=axes[1, 0], shrink=0.9, label="standard deviation of the affordance")
        info = axes[1, 1]
        info.axis("off")
        shows_camera = region[0] <= 0.0 <= region[1] and region[2] <= 0.0 <= region[3]
        marks_legend(
            info,
            camera=shows_camera or not with_image,
            poses=k,
            image=with_image,
            floor="floor point, coloured by the colour bar",
            loc="upper left",
            frameon=False,
            title=f"{pred.model}, robot {pred.robot}",
        )
        lines = []
        if k:
            x, y, yaw = (float(v) for v in pred.poses[0])
            lines.append(
                f"best pose: x {x:.2f} m, y {y:.2f} m, yaw {np.degrees(yaw):.0f}°, "
                f"affordance {float(pred.pose_scores[0]):.2f} "
                f"± {float(pred.pose_uncertainty[0]):.2f}"
            )
        lines.append(f"target {float(np.hypot(*pred.target_xyz[:2])):.2f} m from the camera")
        if correction is not None:
            c = correction
            lines.append(
                f"floor correction: camera height {c.height * 100:+.1f} cm, pitch "
                f"{c.pitch:+.2f}°, roll {c.roll:+.2f}°, depth scale {c.scale:.3f} "
                f"({c.inliers} floor points, residual {c.residual * 1000:.1f} mm)"
            )
        lines += [f"warning: {w}" for w in getattr(pred, "warnings", ())]
        text = "\n".join(textwrap.fill(line, 52, subsequent_indent="  ") for line in lines)
        info.text(0.0, 0.0, text, va="bottom", ha="left", transform=info.transAxes)
        return png_bytes(fig)
