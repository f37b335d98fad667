"""Overview figure of a kitchen: a rendered view and an annotated top-down plan."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.artist import Artist
from matplotlib.colors import to_rgb
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch, Polygon, Wedge
from matplotlib.path import Path as PixelPath
from matplotlib.text import Text

from momakitchen.assets import get_category
from momakitchen.robots import get_robot_spec
from momakitchen.scene.configuration import Configuration, Scene, handle_anchor
from momakitchen.scene.geometry import Footprint, semicircle_grid
from momakitchen.scene.layout import Layout

# The documents show a figure at a page's width (inches), every text at least MIN_POINTS
# large there: momakitchen.perception.figures' DOC_WIDTH and MIN_POINTS, repeated here for
# the scene's and the labels' figures (the scene layer comes before perception).
DOC_WIDTH = 8.6
MIN_POINTS = 8.0
DPI = 120

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
FLOOR_COLOUR = "#f4efe6"
SEMICIRCLE = "#3b82f6"
SEMICIRCLE_EDGE = "#1d4ed8"
# The order of the categories in a legend: the counter's units, what stands on it, the
# objects on the counter, the obstacles on the floor.
KIND_ORDER = {"furniture": 0, "appliance": 1, "rigid": 2, "obstacle": 3}
# Names broken over two lines where a unit is too narrow for them on one.
BROKEN = {"dishwasher": "dish-\nwasher", "microwave": "micro-\nwave"}


def text_sizes(points: float = MIN_POINTS) -> dict[Any, float]:
    """matplotlib settings that set every text of a figure to ``points`` (for
    ``matplotlib.rc_context``; keys typed Any as its stubs list every setting's name)."""
    keys = ["font.size", "axes.titlesize", "axes.labelsize", "xtick.labelsize"]
    keys += ["ytick.labelsize", "legend.fontsize", "legend.title_fontsize", "figure.titlesize"]
    keys += ["figure.labelsize"]
    return dict.fromkeys(keys, points)


def shown(category: str) -> str:
    """A category as a figure names it."""
    return category.replace("_", " ")


@dataclass(frozen=True)
class UnitName:
    """A name to write inside a footprint on a plan (see :func:`name_units`): ``front``
    for a unit on the floor, named near its front edge, clear of what stands on it."""

    text: str
    footprint: Footprint
    ink: str
    fill: tuple[float, float, float]
    front: bool


def _shade(colour: str, alpha: float) -> tuple[float, float, float]:
    """``colour`` drawn with ``alpha`` over the floor."""
    c, floor = np.array(to_rgb(colour)), np.array(to_rgb(FLOOR_COLOUR))
    r, g, b = alpha * c + (1 - alpha) * floor
    return float(r), float(g), float(b)


def _named(text: str, footprint: Footprint, colour: str, alpha: float, front: bool) -> UnitName:
    fill = _shade(colour, alpha)
    light = 0.299 * fill[0] + 0.587 * fill[1] + 0.114 * fill[2] > 0.5
    return UnitName(text, footprint, "black" if light else "white", fill, front)


def _poly(ax, footprint, colour, **kw) -> None:
    ax.add_patch(
        Polygon(
            footprint.corners(), closed=True, facecolor=colour, edgecolor="k", linewidth=0.8, **kw
        )
    )


def draw_kitchen(
    ax, layout: Layout, cfg: Configuration, *, handles: bool = True, alpha: float = 0.95
) -> list[UnitName]:
    """Room, furniture (with handles), objects on the counter and obstacles, top down.
    Returns the names of the units and obstacles, for :func:`name_units` to write once the
    figure's layout is final."""
    room = layout.room
    outline: list[list[float]] = [
        [0, 0],
        [room.width, 0],
        [room.width, room.depth],
        [0, room.depth],
    ]
    ax.add_patch(
        Polygon(outline, closed=True, facecolor=FLOOR_COLOUR, edgecolor="k", linewidth=2, zorder=0)
    )
    names = []
    for unit in layout.furniture:
        fp = unit.footprint()
        colour = PLAN_COLOURS.get(unit.category, "#cccccc")
        _poly(ax, fp, colour, alpha=alpha)
        on_floor = get_category(unit.category).kind == "furniture"
        names.append(_named(shown(unit.category), fp, colour, alpha, on_floor))
        if handles:
            for i in range(len(unit.model.articulations)):
                hx, hy, _ = handle_anchor(unit, i)
                ax.plot(hx, hy, marker="s", ms=3, color="k")
    for obj in cfg.objects:
        _poly(ax, obj.footprint(), PLAN_COLOURS.get(obj.category, "#999999"))
    for ob in cfg.obstacles:
        colour = PLAN_COLOURS.get(ob.category, "#999999")
        _poly(ax, ob.footprint(), colour, alpha=0.9 * alpha)
        names.append(_named(shown(ob.category), ob.footprint(), colour, 0.9 * alpha, False))
    # What stands on the counter and the obstacles first: a unit's name can move.
    return sorted(names, key=lambda n: n.front)


def name_units(ax, names: list[UnitName], pad: float = 2.0) -> list[Text]:
    """Write each name inside its footprint, in MIN_POINTS: on one line or broken over two,
    a unit's near its front edge or else at its centre; clear of the other footprints named
    (what stands on a unit), of the names written before, of the axes' markers (handles,
    the target) and of the scatters drawn over the footprints (the trials). A name that
    fits nowhere is left out: the legend names the footprint's colour. Call once the
    figure's layout and the axes' limits are final (``figure.draw_without_rendering()``);
    ``pad`` in pixels."""
    from matplotlib import patheffects

    frame = ax.get_window_extent().padded(-pad)
    taken = [line.get_window_extent() for line in ax.lines]
    outlines = [PixelPath(ax.transData.transform(n.footprint.corners())) for n in names]
    # The markers of scatters drawn over the footprints (the trials), as (x, y, radius).
    dots = [np.zeros((0, 3))]
    for coll in ax.collections:
        if coll.get_zorder() > 1 and len(coll.get_offsets()):
            xy = coll.get_offset_transform().transform(coll.get_offsets())
            radius = np.sqrt(coll.get_sizes()) / 2 * ax.get_figure().dpi / 72
            dots.append(np.column_stack([xy, np.broadcast_to(radius, len(xy))]))
    marks = np.concatenate(dots)

    def free(box, own: int) -> bool:
        room = box.padded(pad)
        return (
            bool(outlines[own].contains_points(room.corners()).all())
            and frame.contains(box.x0, box.y0)
            and frame.contains(box.x1, box.y1)
            and not any(room.overlaps(other) for other in taken)
            and not any(
                path.intersects_bbox(room, filled=False)
                for k, path in enumerate(outlines)
                if k != own
            )
            and not any(  # a unit's name under what stands on it
                path.contains_point(room.p0 + np.array([room.width, room.height]) / 2)
                for k, path in enumerate(outlines)
                if names[own].front and not names[k].front
            )
            and not _covers(room, marks)
        )

    to_data = ax.transData.inverted()
    written = []
    for own, name in enumerate(names):
        fp = name.footprint
        centre = ax.transData.transform((fp.x, fp.y))
        for form in [name.text, *([BROKEN[name.text]] if name.text in BROKEN else [])]:
            text = ax.text(
                fp.x,
                fp.y,
                form,
                ha="center",
                va="center",
                fontsize=MIN_POINTS,
                color=name.ink,
                zorder=4.5,
                clip_on=True,
                linespacing=1.0,
                path_effects=[patheffects.withStroke(linewidth=2, foreground=name.fill)],
            )
            text.set_in_layout(False)
            spots = [centre]
            if name.front:  # just inside the front edge (a unit stands with its back to y=0)
                edge = ax.transData.transform((fp.x, fp.y + fp.width / 2))
                inward = (centre - edge) / max(float(np.hypot(*(centre - edge))), 1e-9)
                height = text.get_window_extent().height
                spots.insert(0, edge + inward * (abs(height * inward[1]) / 2 + 4 * pad))
            for spot in spots:
                text.set_position(to_data.transform(spot))
                if free(text.get_window_extent(), own):
                    taken.append(text.get_window_extent())
                    written.append(text)
                    break
            else:
                text.remove()
                continue
            break
    return written


def _covers(box, marks: np.ndarray) -> bool:
    """Whether any of ``marks`` ((N, 3): x, y, radius in pixels) touches ``box``."""
    x, y, r = marks.T
    return bool(((x + r > box.x0) & (x - r < box.x1) & (y + r > box.y0) & (y - r < box.y1)).any())


def frame_plan(ax, xlim: tuple[float, float], ylim: tuple[float, float]) -> None:
    """Axes seen from the room towards the wall (wall at the top), like the rendered view."""
    ax.set_xlim(max(xlim), min(xlim))
    ax.set_ylim(max(ylim), min(ylim))
    ax.set_aspect("equal")
    ax.set_xlabel("x, along the wall (m)")
    ax.set_ylabel("y, into the room (m)")


def draw_target(ax, cfg: Configuration) -> None:
    tx, ty, _ = cfg.target.anchor
    ax.plot(tx, ty, marker="*", ms=14, color="red", markeredgecolor="k", zorder=5)


def target_handle(cfg: Configuration) -> Line2D:
    """The legend entry of :func:`draw_target`'s mark."""
    return Line2D(
        [],
        [],
        marker="*",
        ls="",
        ms=12,
        color="red",
        markeredgecolor="k",
        label=f"target: {cfg.target.category}",
    )


def categories(layout: Layout, cfg: Configuration, xlim=None, ylim=None) -> list[str]:
    """The categories of the units, objects and obstacles (those within ``xlim`` x
    ``ylim``, where given), in the legend's order."""
    items = [*layout.furniture, *cfg.objects, *cfg.obstacles]
    found = set()
    for item in items:
        c = item.footprint().corners()
        if xlim is not None and (c[:, 0].max() < min(xlim) or c[:, 0].min() > max(xlim)):
            continue
        if ylim is not None and (c[:, 1].max() < min(ylim) or c[:, 1].min() > max(ylim)):
            continue
        found.add(item.category)
    return sorted(found, key=lambda c: (KIND_ORDER.get(get_category(c).kind, 9), c))


def category_handles(names: list[str], floor: bool = True) -> list[Artist]:
    """Legend entries of the categories' colours (and the room's floor)."""
    handles: list[Artist] = [
        Patch(facecolor=PLAN_COLOURS.get(c, "#ccc"), edgecolor="k", label=shown(c)) for c in names
    ]
    if floor:
        handles.append(Patch(facecolor=FLOOR_COLOUR, edgecolor="k", label="room floor"))
    return handles


def plan_extent(
    scene: Scene, cfg: Configuration
) -> tuple[tuple[float, float], tuple[float, float]]:
    """The plan's view, (x min, x max) and (y min, y max): the whole width of the room, and
    its depth as far as the counter, the sampling semicircle and the obstacles reach (the
    rest is empty floor)."""
    room = scene.layout.room
    ty = cfg.target.anchor[1]
    items = [*scene.layout.furniture, *cfg.objects, *cfg.obstacles]
    far = max(
        [ty + get_robot_spec(cfg.robot).reach]
        + [i.footprint().corners()[:, 1].max() for i in items]
    )
    ymax = room.depth + 0.2 if far + 0.8 >= room.depth else float(far) + 0.35
    return (-0.2, room.width + 0.2), (-0.2, ymax)


def draw_plan(ax, scene: Scene, cfg: Configuration) -> list[UnitName]:
    """Top-down plan: furniture, handles, objects, the target, its semicircle, obstacles.
    Returns the names to write (:func:`name_units`)."""
    names = draw_kitchen(ax, scene.layout, cfg)
    robot = get_robot_spec(cfg.robot)
    tx, ty, _ = cfg.target.anchor
    ax.add_patch(
        Wedge(
            (tx, ty),
            robot.reach,
            0,
            180,
            facecolor=SEMICIRCLE,
            alpha=0.12,
            edgecolor=SEMICIRCLE_EDGE,
            linewidth=1.2,
        )
    )
    grid = semicircle_grid((tx, ty), robot.reach, scene.config.grid_spacing)
    ax.scatter(grid[:, 0], grid[:, 1], s=3, color=SEMICIRCLE_EDGE, alpha=0.6, linewidths=0)
    draw_target(ax, cfg)
    frame_plan(ax, *plan_extent(scene, cfg))
    return names


def plan_handles(scene: Scene, cfg: Configuration) -> list[Artist]:
    """The legend of :func:`draw_plan`: every category's colour and every mark."""
    reach = get_robot_spec(cfg.robot).reach
    spacing = round(scene.config.grid_spacing * 100)
    handles = category_handles(categories(scene.layout, cfg))
    handles += [
        target_handle(cfg),
        Line2D([], [], marker="s", ls="", ms=4, color="k", label="handle / lever"),
        Patch(
            facecolor=SEMICIRCLE,
            alpha=0.25,
            edgecolor=SEMICIRCLE_EDGE,
            label=f"sampling semicircle:\n{cfg.robot}'s reach, {reach} m",
        ),
        Line2D(
            [],
            [],
            marker="o",
            ls="",
            ms=2.5,
            color=SEMICIRCLE_EDGE,
            label=f"a trial's base position\n({spacing} cm grid)",
        ),
    ]
    return handles


def trimmed(rgb: np.ndarray) -> np.ndarray:
    """A rendered view without the rows of white background above (and below) the room."""
    blank = (np.asarray(rgb)[..., :3] >= 250).all(axis=(1, 2))
    if blank.all():
        return rgb
    first, last = np.flatnonzero(~blank)[[0, -1]]
    return rgb[first : last + 1]


def save_overview(scene: Scene, config_index: int, view_rgb: np.ndarray | None, path: Path) -> None:
    """Write the overview PNG, DOC_WIDTH wide: the rendered view (if given) beside the
    legend, above the plan of one configuration (the room's counter side) across the page;
    without a view, the legend below the plan."""
    import matplotlib

    cfg = scene.configurations[config_index]
    room = scene.layout.room
    xlim, ylim = plan_extent(scene, cfg)
    # Laid out in inches, each plot as large as its content (fixed aspects leave no gaps):
    # the plan spans the page, its axes' labels to the left and below it.
    left, right, title, below = 0.7, 0.15, 0.3, 0.55
    plan_w = DOC_WIDTH - left - right
    plan_h = plan_w * (ylim[1] - ylim[0]) / (xlim[1] - xlim[0])
    handles = plan_handles(scene, cfg)
    with matplotlib.rc_context(text_sizes()):
        # A bare Figure (no pyplot): no global state, no display backend needed.
        if view_rgb is not None:
            view_rgb = trimmed(view_rgb)
            view_w = 0.53 * DOC_WIDTH
            view_h = view_w * view_rgb.shape[0] / view_rgb.shape[1]
            top = 0.1 + title + view_h + 0.1
            height = top + title + plan_h + below
            fig = Figure(figsize=(DOC_WIDTH, height), dpi=DPI)

            def place(x: float, y: float, w: float, h: float):
                return fig.add_axes((x / DOC_WIDTH, y / height, w / DOC_WIDTH, h / height))

            view = place(0.1, height - 0.1 - title - view_h, view_w, view_h)
            view.imshow(view_rgb)
            view.set_title(f"scene {scene.layout.scene_id}: rendered view")
            view.axis("off")
            key = place(view_w + 0.3, height - 0.1 - title - view_h, DOC_WIDTH, view_h)
            key.axis("off")
            key.legend(handles=handles, loc="center left", ncols=2, frameon=False)
        else:
            rows = -(-len(handles) // 4) + 1  # the two-line entries: about a row more
            key_h = 0.2 + 0.24 * rows
            height = title + plan_h + below + key_h
            top = 0.0
            fig = Figure(figsize=(DOC_WIDTH, height), dpi=DPI)

            def place(x: float, y: float, w: float, h: float):
                return fig.add_axes((x / DOC_WIDTH, y / height, w / DOC_WIDTH, h / height))

            fig.legend(
                handles=handles,
                loc="upper center",
                bbox_to_anchor=(0.5, key_h / height),
                ncols=4,
                frameon=False,
            )
        ax = place(left, height - title - plan_h - top, plan_w, plan_h)
        names = draw_plan(ax, scene, cfg)
        ax.set_title(
            f"top-down plan, configuration {config_index} (robot {cfg.robot}), "
            f"room {room.width:.2f} x {room.depth:.2f} m"
        )
        fig.draw_without_rendering()
        name_units(ax, names)
        fig.savefig(path, dpi="figure")
