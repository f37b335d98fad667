"""Pictures and recordings of approach episodes: a top-down figure of one episode per
robot, and an MCAP recording of any episode that Foxglove opens.

Both replay the chosen episodes with ``capture`` on (an episode depends only on its
configuration, start, method, policy and the seed, so the replay is the episode that was
scored) to get what the records leave out: the odometry path, the heads of the looks,
their rendered images, the fused map and the kitchen's geometry.
"""

from __future__ import annotations

import base64
import io
import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from momakitchen.errors import MomaError


def replay(
    data: str | Path, result: dict[str, Any], picks: Sequence[dict[str, Any]], methods: dict
) -> list[tuple[dict[str, Any], Any]]:
    """Each picked record run again with capture: ``(record, context)`` pairs (the
    context's free space and target draw the figure; ``record["capture"]["scene"]`` holds
    the kitchen's geometry, :func:`scene_geometry`, for a recording)."""
    from momakitchen.data.reader import dataset_generation, rebuilt_configurations
    from momakitchen.eval.approach.baselines import baseline_goal
    from momakitchen.eval.approach.config import STARTS
    from momakitchen.eval.approach.episode import Episode
    from momakitchen.eval.approach.track import opened_configuration, placed_start

    root = Path(data)
    manifest, gen = dataset_generation(root)
    config = _config(result)
    out = []
    entries = manifest["shards"]
    for pick in picks:
        sid, ci = int(pick["scene_id"]), int(pick["config_index"])
        todo = [(sid, ci, entries[str(sid)]["file"])]
        for scene, shard, _ in rebuilt_configurations(root, todo, gen.scene):
            with opened_configuration(scene, shard, ci, gen, config) as ctx:
                kind, name = pick["start"], pick["method"]
                placed = placed_start(ctx, kind, shard)
                if placed is None:
                    continue
                start, head = placed
                episode = Episode(
                    ctx,
                    start,
                    head,
                    STARTS.index(kind),
                    name,
                    pick["policy"],
                    goal_of=None if name in methods else baseline_goal(ctx, name),
                    perceiver=methods.get(name),
                    capture=True,
                )
                rec = episode.run().to_dict()
                rec.update({k: pick[k] for k in ("scene_id", "config_index", "robot", "start")})
                rec["capture"]["scene"] = scene_geometry(ctx)
                out.append((rec, ctx))
    return out


def _config(result: dict[str, Any]) -> Any:
    """The ApproachConfig a result was run with."""
    from momakitchen.deploy.fusion import LookPolicy
    from momakitchen.eval.approach.config import ApproachConfig
    from momakitchen.sim.motion import MotionConfig

    c = dict(result["config"])
    c.pop("perception_corruption", None)
    c.setdefault("map", "full")  # results from before the static map knew the whole room
    c["look"] = LookPolicy(**c["look"])
    c["motion"] = MotionConfig(**c["motion"])
    for key in ("starts", "policies", "far_range"):
        c[key] = tuple(c[key])
    c["stop_sweep"] = tuple(tuple(s) for s in c["stop_sweep"])
    return ApproachConfig(**c)


def scene_geometry(ctx: Any) -> dict[str, Any]:
    """The configuration's kitchen as plain data (world frame, metres): the room
    (``width`` x ``depth`` x ``wall_height``, the floor at z = 0), one box per furniture
    unit, appliance, counter object and obstacle (``centre`` xyz, ``yaw``, ``size`` xyz),
    the target (its unit or object and its grasp point ``anchor``), the base's footprint
    and the head camera's intrinsics."""
    from momakitchen.assets.registry import get_category

    room = ctx.scene.layout.room
    cfg = ctx.cfg

    def box(p: Any, kind: str) -> dict[str, Any]:
        f = p.footprint()
        height = float(p.model.size[2])
        return {
            "id": f"{kind}/{p.uid}",
            "kind": kind,
            "category": p.category,
            "centre": [f.x, f.y, float(p.z) + height / 2],
            "yaw": f.yaw,
            "size": [f.length, f.width, height],
        }

    units = [box(p, get_category(p.category).kind) for p in ctx.scene.layout.furniture]
    intr = ctx.gen.camera.intrinsics
    return {
        "room": {"width": room.width, "depth": room.depth, "wall_height": room.wall_height},
        "boxes": [
            *units,
            *(box(p, "object") for p in cfg.objects),
            *(box(p, "obstacle") for p in cfg.obstacles),
        ],
        "target": {
            "uid": cfg.target.uid,
            "category": cfg.target.category,
            "anchor": [float(v) for v in cfg.target.anchor],
        },
        "footprint": [float(v) for v in ctx.spec.footprint],
        "intrinsics": [intr.fx, intr.fy, intr.cx, intr.cy, intr.width, intr.height],
    }


def figure_picks(result: dict[str, Any]) -> list[dict[str, Any]]:
    """One episode per robot: the first configuration of each robot, far start if run,
    by the first model method with its most successful policy (else the first row); when
    none of those failed but an episode of that method, policy and start did, the first
    such failure takes its robot's place, so that the figure shows what failing looks
    like."""
    from momakitchen.eval.approach.report import summarize

    rows = summarize(result)
    models = [r for r in rows if r["policy"] != "-"] or rows
    start = "far" if any(r["start"] == "far" for r in models) else models[0]["start"]
    best = max(
        (r for r in models if r["start"] == start and r["method"] == models[0]["method"]),
        key=lambda r: r["success"],
    )
    chosen = (best["method"], best["policy"], start)
    group = [r for r in result["records"] if (r["method"], r["policy"], r["start"]) == chosen]
    picks: dict[str, dict[str, Any]] = {}
    for r in group:
        picks.setdefault(r["robot"], r)
    failed = [r for r in group if not r["success"]]
    if failed and all(r["success"] for r in picks.values()):
        picks[failed[0]["robot"]] = failed[0]
    return list(picks.values())


# The figure's colours: the room's blocked floor, the look cones, the paths.
_BLOCKED = "#c4c4c4"
_LOOK = "#b8860b"
_TRUE_PATH = "#8fb8de"
_ODOM_PATH = "#08306b"


def episode_figure(episodes: Sequence[tuple[dict[str, Any], Any]]) -> bytes:
    """PNG bytes: per episode a top-down plan (x, y in metres, world frame) with the
    floor the base cannot use, the furniture and obstacles, the fused map, the successful
    grid trials, the true and odometry paths, each look's view cone, the goal, the final
    footprint and the outcome; one legend and one colour bar for all. Sized for a page
    860 pixels wide, its text at least 8 pt there."""
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Polygon, Wedge

    from momakitchen.perception.figures import DOC_WIDTH, png_bytes, pyplot, text_sizes
    from momakitchen.scene.geometry import box_corners, corners_of

    plt = pyplot()
    if not episodes:
        raise MomaError("no episode to draw")
    n = len(episodes)
    cols = 1 if n == 1 else 2
    rows = math.ceil(n / cols)
    panel = (DOC_WIDTH - 1.7) / cols  # the colour bar and the axis labels take the rest
    # Each row as tall as its tallest room at the panels' width, with its titles.
    tall = [
        max(ctx.free.ny / ctx.free.nx for _, ctx in episodes[r * cols : (r + 1) * cols])
        for r in range(rows)
    ]
    heights = [panel * a + 0.85 for a in tall]
    with plt.rc_context(text_sizes(8)):
        fig, axes = plt.subplots(
            rows,
            cols,
            figsize=(DOC_WIDTH, sum(heights) + 1.5),
            squeeze=False,
            layout="constrained",
            dpi=150,
            gridspec_kw={"height_ratios": heights},
        )
        scatter = None
        for ax, (rec, ctx) in zip(axes.ravel(), episodes, strict=False):
            free = ctx.free
            grid = free.free.reshape(free.nx, free.ny).T.astype(float)
            extent = (
                -free.step / 2,
                (free.nx - 0.5) * free.step,
                -free.step / 2,
                (free.ny - 0.5) * free.step,
            )
            ax.imshow(
                grid,
                origin="lower",
                extent=extent,
                cmap=ListedColormap([_BLOCKED, "white"]),
                vmin=0,
                vmax=1,
                interpolation="nearest",
            )
            furniture = ctx.scene.layout.footprints() + [o.footprint() for o in ctx.cfg.obstacles]
            for quad in corners_of(furniture):
                ax.add_patch(Polygon(quad, closed=True, fill=False, ec="0.35", lw=0.7))
            cap = rec["capture"]
            if cap["fused"]["xy"]:
                image = _fused_image(cap["fused"], ctx.config.motion.cell)
                scatter = ax.imshow(
                    image[0],
                    origin="lower",
                    extent=image[1],
                    cmap="viridis",
                    vmin=0,
                    vmax=1,
                    interpolation="nearest",
                    zorder=2,
                )
            ok = ctx.labels.trial_stages == 0
            pos = ctx.labels.trial_positions
            ax.scatter(
                pos[ok, 0],
                pos[ok, 1],
                s=7,
                marker="s",
                facecolors="none",
                edgecolors="limegreen",
                lw=0.6,
                zorder=3,
            )
            path = np.asarray(rec.get("path") or [rec["start_pose"][:2]])
            ax.plot(path[:, 0], path[:, 1], "-", color=_TRUE_PATH, lw=4, zorder=4)
            odom = np.asarray(cap["odom_path"] or [rec["start_pose"]])
            ax.plot(odom[:, 0], odom[:, 1], "--", color=_ODOM_PATH, lw=1.0, zorder=5)
            ax.plot(*path[0], "o", mfc="white", mec="black", ms=6, zorder=6)
            intr = ctx.gen.camera.intrinsics
            half = math.degrees(math.atan(intr.width / (2 * intr.fx)))
            for look, head in zip(rec["looks"], cap["heads"], strict=True):
                x, y, yaw = look["true"]
                h = np.asarray(head).reshape(4, 4)
                cam_yaw = math.degrees(yaw + math.atan2(h[1, 2], h[0, 2]))
                ax.add_patch(
                    Wedge(
                        (x, y),
                        1.5,
                        cam_yaw - half,
                        cam_yaw + half,
                        fc="none",
                        ec=_LOOK,
                        lw=1.1,
                        zorder=4,
                    )
                )
                ax.plot(x, y, "o", color=_LOOK, ms=4, zorder=6)
            if rec.get("goal"):
                ax.plot(
                    *rec["goal"][:2], "*", color="magenta", mec="black", mew=0.5, ms=11, zorder=8
                )
            if rec.get("final"):
                x, y, yaw = rec["final"]
                corners = box_corners(x, y, yaw, *ctx.spec.footprint)[0]
                colour = "tab:green" if rec["success"] else "tab:red"
                ax.add_patch(Polygon(corners, closed=True, fill=False, ec=colour, lw=1.6, zorder=7))
                ax.arrow(
                    x,
                    y,
                    0.3 * math.cos(yaw),
                    0.3 * math.sin(yaw),
                    width=0.02,
                    color=colour,
                    zorder=7,
                )
            ax.plot(*ctx.anchor[:2], "x", color="red", ms=9, mew=2.2, zorder=8)
            verdict = "success" if rec["success"] else f"failed ({rec['stage']})"
            ax.set_title(
                f"{rec['robot']}, scene {rec['scene_id']}/{rec['config_index']}: {verdict}\n"
                f"{rec['method']} ({rec['policy']}), {rec['start']} start, "
                f"{len(rec['looks'])} looks",
                color="black" if rec["success"] else "tab:red",
            )
            ax.set_aspect("equal")
            ax.set_xlim(extent[0], extent[1])
            ax.set_ylim(extent[2], extent[3])
            ax.set_xlabel("x (m)")
            ax.set_ylabel("y (m)")
        for ax in axes.ravel()[n:]:
            ax.axis("off")
        fig.legend(handles=_legend_handles(), loc="outside lower center", ncols=3)
        if scatter is not None:
            fig.colorbar(
                scatter, ax=axes, shrink=0.5, location="right", label="fused affordance (0–1)"
            )
        return png_bytes(fig)


# Fused cells below this affordance are left out of the figure: the floor the looks saw
# and the map calls poor would hide the plan.
_SHOWN = 0.05


def _fused_image(fused: dict[str, Any], cell: float) -> tuple[np.ndarray, tuple]:
    """The fused map's cells of affordance >= _SHOWN as an image (NaN elsewhere) and its
    extent (x min, x max, y min, y max) for ``imshow(origin="lower")``."""
    xy = np.asarray(fused["xy"], float).reshape(-1, 2)
    value = np.asarray(fused["value"], float)
    ij = np.floor(xy / cell).astype(int)
    lo = ij.min(0)
    image = np.full(tuple(ij.max(0) - lo + 1)[::-1], np.nan)
    shown = value >= _SHOWN
    image[ij[shown, 1] - lo[1], ij[shown, 0] - lo[0]] = value[shown]
    hi = ij.max(0) + 1
    return image, (lo[0] * cell, hi[0] * cell, lo[1] * cell, hi[1] * cell)


def _legend_handles() -> list[Any]:
    """One legend entry per kind of mark of :func:`episode_figure`."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    def mark(marker: str, label: str, **kw: Any) -> Line2D:
        return Line2D([], [], marker=marker, ls="", label=label, **kw)

    return [
        Patch(fc=_BLOCKED, label="floor the base cannot use"),
        Patch(fc="none", ec="0.35", label="furniture, obstacle"),
        mark("s", "fused map, affordance ≥ 0.05", color=(0.13, 0.57, 0.55), ms=5),
        mark("s", "successful labelled trial", mfc="none", mec="limegreen", ms=6),
        mark("o", "start", mfc="white", mec="black", ms=6),
        Line2D([], [], color=_TRUE_PATH, lw=4, label="true path"),
        Line2D([], [], color=_ODOM_PATH, lw=1.0, ls="--", label="odometry's path"),
        mark("o", "look (base position)", color=_LOOK, ms=4),
        Patch(fc="none", ec=_LOOK, label="camera's view, 1.5 m"),
        mark("*", "goal", color="magenta", mec="black", mew=0.5, ms=11),
        Patch(fc="none", ec="tab:green", lw=1.6, label="final footprint: success"),
        Patch(fc="none", ec="tab:red", lw=1.6, label="final footprint: failure"),
        mark("x", "target", color="red", ms=9, mew=2.2),
    ]


# --------------------------------------------------------------------------- recording
# JSON schemas of the Foxglove messages the recording writes, built from the message
# definitions (https://docs.foxglove.dev/docs/visualization/message-schemas): ``bytes``
# fields are base64 strings, enums integers, times {sec, nsec}.
def _s(kind: str, description: str = "", **kw: Any) -> dict[str, Any]:
    return {"type": kind, **({"description": description} if description else {}), **kw}


def _object(title: str, props: dict[str, Any], required: bool = True) -> dict[str, Any]:
    doc: dict[str, Any] = {"title": title, "type": "object", "properties": props}
    if required:
        doc["required"] = list(props)
    return doc


def _enum(title: str, names: Sequence[str]) -> dict[str, Any]:
    return {"title": title, "oneOf": [{"title": n, "const": i} for i, n in enumerate(names)]}


def _array(items: dict[str, Any], n: int | None = None) -> dict[str, Any]:
    fixed = {"minItems": n, "maxItems": n} if n is not None else {}
    return {"type": "array", "items": items, **fixed}


_TIME = _object(
    "time",
    {
        "sec": _s("integer", minimum=0),
        "nsec": _s("integer", minimum=0, maximum=999_999_999),
    },
)
_DURATION = _object(
    "duration",
    {"sec": _s("integer"), "nsec": _s("integer", minimum=0, maximum=999_999_999)},
)
_VECTOR3 = _object("foxglove.Vector3", {k: _s("number") for k in "xyz"})
_POINT3 = _object("foxglove.Point3", {k: _s("number") for k in "xyz"})
_QUATERNION = _object("foxglove.Quaternion", {k: _s("number") for k in "xyzw"})
_POSE = _object("foxglove.Pose", {"position": _VECTOR3, "orientation": _QUATERNION})
_COLOR = _object("foxglove.Color", {k: _s("number", minimum=0, maximum=1) for k in "rgba"})
_BYTES = _s("string", contentEncoding="base64")
_FRAME = _s("string", "frame of reference")
_PRIMITIVES = {
    "arrows": _object(
        "foxglove.ArrowPrimitive",
        {
            "pose": _POSE,
            **{k: _s("number") for k in ("shaft_length", "shaft_diameter")},
            **{k: _s("number") for k in ("head_length", "head_diameter")},
            "color": _COLOR,
        },
    ),
    "cubes": _object("foxglove.CubePrimitive", {"pose": _POSE, "size": _VECTOR3, "color": _COLOR}),
    "spheres": _object(
        "foxglove.SpherePrimitive", {"pose": _POSE, "size": _VECTOR3, "color": _COLOR}
    ),
    "cylinders": _object(
        "foxglove.CylinderPrimitive",
        {
            "pose": _POSE,
            "size": _VECTOR3,
            "bottom_scale": _s("number"),
            "top_scale": _s("number"),
            "color": _COLOR,
        },
    ),
    "lines": _object(
        "foxglove.LinePrimitive",
        {
            "type": _enum("foxglove.LineType", ("LINE_STRIP", "LINE_LOOP", "LINE_LIST")),
            "pose": _POSE,
            "thickness": _s("number"),
            "scale_invariant": _s("boolean"),
            "points": _array(_POINT3),
            "color": _COLOR,
            "colors": _array(_COLOR),
            "indices": _array(_s("integer", minimum=0)),
        },
        required=False,
    ),
    "triangles": _object(
        "foxglove.TriangleListPrimitive",
        {
            "pose": _POSE,
            "points": _array(_POINT3),
            "color": _COLOR,
            "colors": _array(_COLOR),
            "indices": _array(_s("integer", minimum=0)),
        },
        required=False,
    ),
    "texts": _object(
        "foxglove.TextPrimitive",
        {
            "pose": _POSE,
            "billboard": _s("boolean"),
            "font_size": _s("number"),
            "scale_invariant": _s("boolean"),
            "color": _COLOR,
            "text": _s("string"),
        },
    ),
    "models": _object(
        "foxglove.ModelPrimitive",
        {
            "pose": _POSE,
            "scale": _VECTOR3,
            "color": _COLOR,
            "override_color": _s("boolean"),
            "url": _s("string"),
            "media_type": _s("string"),
            "data": _BYTES,
        },
        required=False,
    ),
}
_ENTITY = _object(
    "foxglove.SceneEntity",
    {
        "timestamp": _TIME,
        "frame_id": _FRAME,
        "id": _s("string", "replaces any earlier entity of the topic with this id"),
        "lifetime": _DURATION,
        "frame_locked": _s("boolean"),
        "metadata": _array(
            _object("foxglove.KeyValuePair", {"key": _s("string"), "value": _s("string")})
        ),
        **{name: _array(item) for name, item in _PRIMITIVES.items()},
    },
    required=False,
)
_NUMERIC = ("UNKNOWN", "UINT8", "INT8", "UINT16", "INT16", "UINT32", "INT32", "FLOAT32", "FLOAT64")
_MESSAGES: dict[str, dict[str, Any]] = {
    "foxglove.PoseInFrame": {"timestamp": _TIME, "frame_id": _FRAME, "pose": _POSE},
    "foxglove.PosesInFrame": {"timestamp": _TIME, "frame_id": _FRAME, "poses": _array(_POSE)},
    "foxglove.PointCloud": {
        "timestamp": _TIME,
        "frame_id": _FRAME,
        "pose": _POSE,
        "point_stride": _s("integer", minimum=0),
        "fields": _array(
            _object(
                "foxglove.PackedElementField",
                {
                    "name": _s("string"),
                    "offset": _s("integer", minimum=0),
                    "type": _enum("foxglove.NumericType", _NUMERIC),
                },
            )
        ),
        "data": _BYTES,
    },
    "foxglove.Log": {
        "timestamp": _TIME,
        "level": _enum(
            "foxglove.LogLevel", ("UNKNOWN", "DEBUG", "INFO", "WARNING", "ERROR", "FATAL")
        ),
        "message": _s("string"),
        "name": _s("string"),
        "file": _s("string"),
        "line": _s("integer", minimum=0),
    },
    "foxglove.SceneUpdate": {
        "deletions": _array(
            _object(
                "foxglove.SceneEntityDeletion",
                {
                    "timestamp": _TIME,
                    "type": _enum("foxglove.SceneEntityDeletionType", ("MATCHING_ID", "ALL")),
                    "id": _s("string"),
                },
            )
        ),
        "entities": _array(_ENTITY),
    },
    "foxglove.FrameTransform": {
        "timestamp": _TIME,
        "parent_frame_id": _s("string"),
        "child_frame_id": _s("string"),
        "translation": _VECTOR3,
        "rotation": _QUATERNION,
    },
    "foxglove.CameraCalibration": {
        "timestamp": _TIME,
        "frame_id": _s("string", "the camera's optical frame: x right, y down, z forward"),
        "width": _s("integer", minimum=0),
        "height": _s("integer", minimum=0),
        "distortion_model": _s("string"),
        "D": _array(_s("number")),
        "K": _array(_s("number"), 9),
        "R": _array(_s("number"), 9),
        "P": _array(_s("number"), 12),
    },
    "foxglove.CompressedImage": {
        "timestamp": _TIME,
        "frame_id": _FRAME,
        "data": _BYTES,
        "format": _s("string", "png, jpeg, webp or avif"),
    },
    "foxglove.RawImage": {
        "timestamp": _TIME,
        "frame_id": _FRAME,
        "width": _s("integer", minimum=0),
        "height": _s("integer", minimum=0),
        "encoding": _s("string"),
        "step": _s("integer", minimum=0, description="bytes per row"),
        "data": _BYTES,
    },
}


def message_schema(name: str) -> dict[str, Any]:
    """The JSON schema of Foxglove message ``name`` (e.g. ``foxglove.SceneUpdate``)."""
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        **_object(name, _MESSAGES[name], required=False),
    }


def _schema(name: str) -> bytes:
    return json.dumps(message_schema(name), allow_nan=False).encode()


# The recording's topics and their message types.
TOPICS = {
    "/approach/scene": "foxglove.SceneUpdate",
    "/approach/tf": "foxglove.FrameTransform",
    "/approach/base": "foxglove.PoseInFrame",
    "/approach/odom": "foxglove.PoseInFrame",
    "/approach/path": "foxglove.PosesInFrame",
    "/approach/looks": "foxglove.PosesInFrame",
    "/approach/camera/calibration": "foxglove.CameraCalibration",
    "/approach/camera/rgb": "foxglove.CompressedImage",
    "/approach/camera/depth": "foxglove.RawImage",
    "/approach/goal": "foxglove.PoseInFrame",
    "/approach/fused_map": "foxglove.PointCloud",
    "/approach/outcome": "foxglove.Log",
}


def _quaternion(rotation: np.ndarray) -> dict[str, float]:
    """A rotation matrix (3, 3) as a unit quaternion {x, y, z, w}."""
    m = np.asarray(rotation, float)
    trace = m[0, 0] + m[1, 1] + m[2, 2]
    if trace > 0:
        s = 2.0 * math.sqrt(trace + 1.0)
        q = (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, s / 4
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = s / 4, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s, (m[2, 1] - m[1, 2]) / s
    elif m[1, 1] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = (m[0, 1] + m[1, 0]) / s, s / 4, (m[1, 2] + m[2, 1]) / s, (m[0, 2] - m[2, 0]) / s
    else:
        s = 2.0 * math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, s / 4, (m[1, 0] - m[0, 1]) / s
    norm = math.sqrt(sum(v * v for v in q))
    x, y, z, w = (float(v) / norm for v in q)
    return {"x": x, "y": y, "z": z, "w": w}


def _yaw_quaternion(yaw: float) -> dict[str, float]:
    return {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}


def _pose(x: float, y: float, yaw: float, z: float = 0.0) -> dict[str, Any]:
    return {"position": {"x": x, "y": y, "z": z}, "orientation": _yaw_quaternion(yaw)}


def _colour(r: float, g: float, b: float, a: float = 1.0) -> dict[str, float]:
    return {"r": r, "g": g, "b": b, "a": a}


def _cube(centre: Sequence[float], yaw: float, size: Sequence[float], colour: dict) -> dict:
    return {
        "pose": _pose(float(centre[0]), float(centre[1]), float(yaw), float(centre[2])),
        "size": {"x": float(size[0]), "y": float(size[1]), "z": float(size[2])},
        "color": colour,
    }


def _text(xyz: Sequence[float], text: str, colour: dict, size: float = 14.0) -> dict:
    return {
        "pose": _pose(float(xyz[0]), float(xyz[1]), 0.0, float(xyz[2])),
        "billboard": True,
        "font_size": size,
        "scale_invariant": True,
        "color": colour,
        "text": text,
    }


def _entity(
    stamp: dict[str, int],
    eid: str,
    cubes: Sequence[dict] = (),
    texts: Sequence[dict] = (),
    arrows: Sequence[dict] = (),
    metadata: dict[str, str] | None = None,
) -> dict[str, Any]:
    """A SceneEntity in the world frame that stays until replaced (lifetime 0)."""
    return {
        "timestamp": stamp,
        "frame_id": "world",
        "id": eid,
        "lifetime": {"sec": 0, "nsec": 0},
        "frame_locked": False,
        "metadata": [{"key": k, "value": v} for k, v in (metadata or {}).items()],
        "arrows": list(arrows),
        "cubes": list(cubes),
        "spheres": [],
        "cylinders": [],
        "lines": [],
        "triangles": [],
        "texts": list(texts),
        "models": [],
    }


# Colours (r, g, b) of the scene's boxes by kind.
_BOX_COLOURS = {
    "furniture": (0.62, 0.5, 0.38),
    "appliance": (0.55, 0.57, 0.6),
    "object": (0.35, 0.6, 0.85),
    "obstacle": (0.95, 0.55, 0.1),
}
_WALL = 0.05  # m, the walls' thickness in the scene


def _scene_entities(geometry: dict[str, Any], stamp: dict[str, int]) -> list[dict[str, Any]]:
    """The room (floor and four walls), one entity per box and the target."""
    room = geometry["room"]
    w, d, h = room["width"], room["depth"], room["wall_height"]
    wall = _colour(0.85, 0.85, 0.8, 0.35)  # see-through: the camera looks in from above
    cubes = [
        _cube((w / 2, d / 2, -0.005), 0.0, (w, d, 0.01), _colour(0.93, 0.92, 0.88)),
        _cube((w / 2, -_WALL / 2, h / 2), 0.0, (w + 2 * _WALL, _WALL, h), wall),
        _cube((w / 2, d + _WALL / 2, h / 2), 0.0, (w + 2 * _WALL, _WALL, h), wall),
        _cube((-_WALL / 2, d / 2, h / 2), 0.0, (_WALL, d, h), wall),
        _cube((w + _WALL / 2, d / 2, h / 2), 0.0, (_WALL, d, h), wall),
    ]
    sizes = {"width": f"{w:g} m", "depth": f"{d:g} m", "wall_height": f"{h:g} m"}
    out = [_entity(stamp, "room", cubes, metadata=sizes)]
    target = geometry["target"]
    for b in geometry["boxes"]:
        is_target = b["id"].endswith("/" + target["uid"])
        rgb = (0.85, 0.25, 0.2) if is_target else _BOX_COLOURS.get(b["kind"], (0.6, 0.6, 0.6))
        cube = _cube(b["centre"], b["yaw"], b["size"], _colour(*rgb, 0.9))
        meta = {"kind": b["kind"], "category": b["category"], "target": str(is_target).lower()}
        out.append(_entity(stamp, b["id"], [cube], metadata=meta))
    anchor = target["anchor"]
    red = _colour(0.9, 0.1, 0.1)
    out.append(
        _entity(
            stamp,
            "target",
            [_cube(anchor, 0.0, (0.06, 0.06, 0.06), red)],
            [_text((anchor[0], anchor[1], anchor[2] + 0.15), f"target: {target['category']}", red)],
            metadata={"uid": target["uid"], "category": target["category"]},
        )
    )
    return out


def _outcome_entity(rec: dict[str, Any], geometry: dict[str, Any], stamp: dict) -> dict:
    """Where the trial ran: the base's footprint (green: success; red: failure) and the
    verdict; without a trial, the verdict where the base stopped."""
    verdict = "success" if rec["success"] else f"failure: {rec['stage']}"
    rgb = (0.1, 0.7, 0.2) if rec["success"] else (0.85, 0.1, 0.1)
    if rec.get("final"):
        x, y, yaw = rec["final"]
        length, width = geometry["footprint"]
        cube = _cube((x, y, 0.1), yaw, (length, width, 0.2), _colour(*rgb, 0.6))
        arrow = {
            "pose": _pose(x, y, yaw, 0.25),
            "shaft_length": 0.3,
            "shaft_diameter": 0.03,
            "head_length": 0.1,
            "head_diameter": 0.08,
            "color": _colour(*rgb),
        }
        text = _text((x, y, 0.6), verdict, _colour(*rgb))
        return _entity(stamp, "outcome", [cube], [text], [arrow], {"stage": rec["stage"]})
    x, y = (rec.get("path") or [rec["start_pose"][:2]])[-1]
    return _entity(stamp, "outcome", [], [_text((x, y, 0.6), verdict, _colour(*rgb))])


def _path_yaws(true: np.ndarray, odom: np.ndarray) -> np.ndarray:
    """The heading of each true path point: the odometry's yaw at the same step (the
    base turns to face the target as it drives); where the two do not pair up, the
    direction of travel."""
    if len(odom) == len(true):
        return odom[:, 2].astype(float)
    step = np.diff(true, axis=0, append=true[-1:])
    yaws = np.arctan2(step[:, 1], step[:, 0])
    for i in range(len(yaws) - 1, 0, -1):  # no motion: the heading before
        if not step[i].any():
            yaws[i] = yaws[i - 1]
    return yaws


def _look_steps(true: np.ndarray, looks: Sequence[dict[str, Any]]) -> list[int]:
    """The path index at which each look was taken (looks in order along the path)."""
    out, at = [], 0
    for look in looks:
        d = np.hypot(*(true[at:] - np.asarray(look["true"][:2])).T)
        at += int(np.argmin(d))
        out.append(at)
    return out


def _png(array: np.ndarray) -> bytes:
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(array)).save(buf, format="PNG")
    return buf.getvalue()


def write_mcap(path: str | Path, rec: dict[str, Any], speed: float) -> None:
    """An MCAP file (JSON messages with Foxglove's JSON schemas) of one captured episode
    (:func:`replay`) in the ``world`` frame (the room's, the odometry's at the start; z up,
    the floor at z = 0), on a clock of the robot's driving time:

    - ``/approach/scene`` (SceneUpdate): the room, every furniture unit, appliance,
      counter object and obstacle as a box, the target; at the end the outcome (the
      final footprint, its heading and the verdict);
    - ``/approach/tf`` (FrameTransform): ``world`` to ``base`` along the path, and to
      ``look_K``, the camera of look K (optical axes: x right, y down, z forward);
    - ``/approach/camera/rgb`` (CompressedImage, PNG), ``/approach/camera/depth``
      (RawImage, 16UC1 in millimetres), ``/approach/camera/calibration``: each look's
      rendered view in its ``look_K`` frame;
    - ``/approach/base``, ``/approach/odom`` (PoseInFrame): the true pose and what
      odometry says; ``/approach/path`` (PosesInFrame): the true path, each pose heading
      as the base did (the odometry's yaw); ``/approach/looks``, ``/approach/goal``;
    - ``/approach/fused_map`` (PointCloud: x, y, z, affordance) and ``/approach/outcome``
      (Log)."""
    from mcap.writer import Writer

    from momakitchen.fileio import atomic_path
    from momakitchen.frames import base_to_world

    cap = rec["capture"]
    geometry = cap.get("scene")
    true = np.asarray(rec.get("path") or [rec["start_pose"][:2]], float)
    odom = np.asarray(cap["odom_path"] or [rec["start_pose"]], float)
    yaws = _path_yaws(true, odom)
    steps = np.r_[0.0, np.cumsum(np.hypot(*np.diff(true, axis=0).T))] / speed
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        w = Writer(f)
        w.start(profile="", library="momakitchen")
        channels = {}
        schemas: dict[str, int] = {}
        for topic, schema in TOPICS.items():
            if schema not in schemas:
                schemas[schema] = w.register_schema(
                    name=schema, encoding="jsonschema", data=_schema(schema)
                )
            channels[topic] = w.register_channel(
                topic=topic, message_encoding="json", schema_id=schemas[schema]
            )

        def stamp_of(t: float) -> dict[str, int]:
            ns = round(t * 1e9)
            return {"sec": ns // 10**9, "nsec": ns % 10**9}

        def put(topic: str, t: float, msg: dict[str, Any], stamped: bool = True) -> None:
            ns = round(t * 1e9)
            body = {"timestamp": stamp_of(t), **msg} if stamped else msg
            data = json.dumps(body, allow_nan=False).encode()
            w.add_message(channels[topic], log_time=ns, data=data, publish_time=ns)

        def transform(t: float, child: str, matrix: np.ndarray) -> None:
            x, y, z = (float(v) for v in matrix[:3, 3])
            put(
                "/approach/tf",
                t,
                {
                    "parent_frame_id": "world",
                    "child_frame_id": child,
                    "translation": {"x": x, "y": y, "z": z},
                    "rotation": _quaternion(matrix[:3, :3]),
                },
            )

        if geometry is not None:
            put(
                "/approach/scene",
                0.0,
                {"deletions": [], "entities": _scene_entities(geometry, stamp_of(0.0))},
                stamped=False,
            )
        for k, (x, y) in enumerate(true):
            o = odom[min(k, len(odom) - 1)]
            put("/approach/base", steps[k], {"frame_id": "world", "pose": _pose(x, y, yaws[k])})
            put("/approach/odom", steps[k], {"frame_id": "world", "pose": _pose(*o)})
            transform(steps[k], "base", base_to_world((x, y, float(yaws[k]))))
        images = cap.get("images") or []
        for i, k in enumerate(_look_steps(true, rec["looks"])):
            frame, t = f"look_{i}", float(steps[k])
            head = np.asarray(cap["heads"][i], float).reshape(4, 4)
            transform(t, frame, base_to_world(tuple(rec["looks"][i]["true"])) @ head)
            shot = images[i] if i < len(images) else None
            if shot is None or geometry is None:
                continue
            rgb, depth, s = np.asarray(shot["rgb"]), np.asarray(shot["depth"]), shot["stride"]
            fx, fy, cx, cy = (v / s for v in geometry["intrinsics"][:4])
            height, width = depth.shape
            put(
                "/approach/camera/calibration",
                t,
                {
                    "frame_id": frame,
                    "width": width,
                    "height": height,
                    "distortion_model": "plumb_bob",
                    "D": [0.0] * 5,
                    "K": [fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0],
                    "R": [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
                    "P": [fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0],
                },
            )
            put(
                "/approach/camera/rgb",
                t,
                {
                    "frame_id": frame,
                    "data": base64.b64encode(_png(rgb)).decode(),
                    "format": "png",
                },
            )
            mm = np.clip(np.nan_to_num(depth) * 1000.0, 0, 65535).round().astype("<u2")
            put(
                "/approach/camera/depth",
                t,
                {
                    "frame_id": frame,
                    "width": width,
                    "height": height,
                    "encoding": "16UC1",
                    "step": 2 * width,
                    "data": base64.b64encode(mm.tobytes()).decode(),
                },
            )
        end = float(steps[-1])
        put(
            "/approach/path",
            end,
            {
                "frame_id": "world",
                "poses": [_pose(x, y, yaw) for (x, y), yaw in zip(true, yaws, strict=True)],
            },
        )
        looks = [_pose(*look["true"]) for look in rec["looks"]]
        put("/approach/looks", end, {"frame_id": "world", "poses": looks})
        if rec.get("goal"):
            put("/approach/goal", end, {"frame_id": "world", "pose": _pose(*rec["goal"])})
        xy = np.asarray(cap["fused"]["xy"], np.float32).reshape(-1, 2)
        pts = np.column_stack(
            [xy, np.zeros(len(xy), np.float32), np.asarray(cap["fused"]["value"], np.float32)]
        ).astype(np.float32)
        fields = [
            {"name": n, "offset": 4 * i, "type": 7}
            for i, n in enumerate(("x", "y", "z", "affordance"))
        ]
        put(
            "/approach/fused_map",
            end,
            {
                "frame_id": "world",
                "pose": _pose(0.0, 0.0, 0.0),
                "point_stride": 16,
                "fields": fields,
                "data": base64.b64encode(pts.tobytes()).decode(),
            },
        )
        if geometry is not None:
            update = {"deletions": [], "entities": [_outcome_entity(rec, geometry, stamp_of(end))]}
            put("/approach/scene", end, update, stamped=False)
        verdict = "success" if rec["success"] else f"failure: {rec['stage']}"
        message = f"{rec['method']} ({rec['policy']}), {rec['start']} start: {verdict}"
        put(
            "/approach/outcome",
            end,
            {
                "level": 2 if rec["success"] else 3,  # INFO, WARNING
                "message": message,
                "name": "approach",
                "file": "",
                "line": 0,
            },
        )
        w.finish()
