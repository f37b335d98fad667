"""Pictures and recordings of approach episodes: a top-down figure of one episode per
robot, and an MCAP recording of any episode that Foxglove opens.

Both replay the chosen episodes with ``capture`` on (an episode depends only on its
configuration, start, method, policy and the seed, so the replay is the episode that was
scored) to get what the records leave out: the odometry path, the heads of the looks and
the fused map.
"""

from __future__ import annotations

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
    context's free space and target draw the figure)."""
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


def figure_picks(result: dict[str, Any]) -> list[dict[str, Any]]:
    """One episode per robot: the first configuration of each robot, far start if run,
    by the first model method with its most successful policy (else the first row)."""
    from momakitchen.eval.approach.report import summarize

    rows = summarize(result)
    models = [r for r in rows if r["policy"] != "-"] or rows
    start = "far" if any(r["start"] == "far" for r in models) else models[0]["start"]
    best = max(
        (r for r in models if r["start"] == start and r["method"] == models[0]["method"]),
        key=lambda r: r["success"],
    )
    picks, seen = [], set()
    for r in result["records"]:
        key = (r["method"], r["policy"], r["start"])
        if key == (best["method"], best["policy"], start) and r["robot"] not in seen:
            seen.add(r["robot"])
            picks.append(r)
    return picks


def episode_figure(episodes: Sequence[tuple[dict[str, Any], Any]]) -> bytes:
    """PNG bytes: per episode a top-down plan with the free space, the fused map, the
    true and odometry paths, each look's view cone, the goal, the final pose and the
    outcome."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Polygon, Wedge

    if not episodes:
        raise MomaError("no episode to draw")
    n = len(episodes)
    cols = min(3, n)
    rows = math.ceil(n / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(5.2 * cols, 3.2 * rows), squeeze=False)
    scatter = None
    for ax, (rec, ctx) in zip(axes.ravel(), episodes, strict=False):
        free = ctx.free
        grid = free.free.reshape(free.nx, free.ny).T
        extent = (
            -free.step / 2,
            (free.nx - 0.5) * free.step,
            -free.step / 2,
            (free.ny - 0.5) * free.step,
        )
        ax.imshow(grid, origin="lower", extent=extent, cmap="Greys_r", vmin=-1.5, vmax=1, alpha=0.6)
        cap = rec["capture"]
        if cap["fused"]["xy"]:
            xy = np.asarray(cap["fused"]["xy"])
            value = np.asarray(cap["fused"]["value"])
            lit = value >= 0.05  # the seen floor the map calls poor stays a light wash
            ax.scatter(*xy[~lit].T, s=3, color="lightsteelblue", alpha=0.35, lw=0)
            scatter = ax.scatter(
                *xy[lit].T, c=value[lit], s=5, cmap="viridis", vmin=0, vmax=1, lw=0
            )
        ok = ctx.labels.trial_stages == 0
        pos = ctx.labels.trial_positions
        ax.scatter(
            pos[ok, 0],
            pos[ok, 1],
            s=6,
            marker="s",
            facecolors="none",
            edgecolors="limegreen",
            lw=0.6,
        )
        path = np.asarray(rec.get("path") or [rec["start_pose"][:2]])
        ax.plot(path[:, 0], path[:, 1], "-", color="tab:blue", lw=1.6, label="true path")
        odom = np.asarray(cap["odom_path"] or [rec["start_pose"]])
        ax.plot(odom[:, 0], odom[:, 1], "--", color="tab:orange", lw=1.2, label="odometry")
        intr = ctx.gen.camera.intrinsics
        half = math.degrees(math.atan(intr.width / (2 * intr.fx)))
        for look, head in zip(rec["looks"], cap["heads"], strict=True):
            x, y, yaw = look["true"]
            h = np.asarray(head).reshape(4, 4)
            cam_yaw = math.degrees(yaw + math.atan2(h[1, 2], h[0, 2]))
            ax.add_patch(
                Wedge((x, y), 1.5, cam_yaw - half, cam_yaw + half, fc="none", ec="goldenrod", lw=1)
            )
            ax.plot(x, y, "o", color="goldenrod", ms=4)
        if rec.get("goal"):
            ax.plot(*rec["goal"][:2], "*", color="magenta", ms=12, label="goal")
        if rec.get("final"):
            x, y, yaw = rec["final"]
            fp = ctx.spec.footprint
            from momakitchen.scene.geometry import box_corners

            corners = box_corners(x, y, yaw, *fp)[0]
            colour = "tab:green" if rec["success"] else "tab:red"
            ax.add_patch(Polygon(corners, closed=True, fill=False, ec=colour, lw=1.5))
            ax.arrow(x, y, 0.3 * math.cos(yaw), 0.3 * math.sin(yaw), width=0.015, color=colour)
        ax.plot(*ctx.anchor[:2], "x", color="red", ms=9, mew=2, label="target")
        verdict = "success" if rec["success"] else f"failed: {rec['stage']}"
        ax.set_title(
            f"{rec['robot']}: scene {rec['scene_id']} / {rec['config_index']}, {rec['start']} "
            f"start\n{rec['method']} ({rec['policy']}), {len(rec['looks'])} looks: {verdict}",
            fontsize=9,
        )
        ax.set_aspect("equal")
        ax.set_xlim(extent[0], extent[1])
        ax.set_ylim(extent[2], extent[3])
        ax.tick_params(labelsize=7)
    for ax in axes.ravel()[n:]:
        ax.axis("off")
    axes.ravel()[0].legend(loc="upper right", fontsize=7)
    if scatter is not None:
        fig.colorbar(scatter, ax=axes.ravel().tolist(), shrink=0.6, label="fused affordance")
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    return buf.getvalue()


# --------------------------------------------------------------------------- recording
_SCHEMAS = {
    "foxglove.PoseInFrame": ["timestamp", "frame_id", "pose"],
    "foxglove.PosesInFrame": ["timestamp", "frame_id", "poses"],
    "foxglove.PointCloud": ["timestamp", "frame_id", "pose", "point_stride", "fields", "data"],
    "foxglove.Log": ["timestamp", "level", "message", "name", "file", "line"],
}


def _schema(name: str) -> bytes:
    props: dict[str, dict] = {k: {} for k in _SCHEMAS[name]}
    doc = {"title": name, "type": "object", "properties": props}
    return json.dumps(doc, allow_nan=False).encode()


def _pose(x: float, y: float, yaw: float) -> dict[str, Any]:
    return {
        "position": {"x": x, "y": y, "z": 0.0},
        "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)},
    }


def write_mcap(path: str | Path, rec: dict[str, Any], speed: float) -> None:
    """An MCAP file (JSON messages, Foxglove schemas) of one captured episode, in the
    world frame, on a clock of the robot's driving time: ``/approach/base`` (true pose),
    ``/approach/odom`` (what odometry says), ``/approach/path``, ``/approach/looks``,
    ``/approach/goal``, ``/approach/fused_map`` (x, y, z, affordance) and
    ``/approach/outcome``."""
    from mcap.writer import Writer

    from momakitchen.fileio import atomic_path

    cap = rec["capture"]
    true = np.asarray(rec.get("path") or [rec["start_pose"][:2]], float)
    odom = np.asarray(cap["odom_path"] or [rec["start_pose"]], float)
    steps = np.r_[0.0, np.cumsum(np.hypot(*np.diff(true, axis=0).T))] / speed
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        w = Writer(f)
        w.start(profile="", library="momakitchen")
        channels = {}
        for topic, schema in (
            ("/approach/base", "foxglove.PoseInFrame"),
            ("/approach/odom", "foxglove.PoseInFrame"),
            ("/approach/path", "foxglove.PosesInFrame"),
            ("/approach/looks", "foxglove.PosesInFrame"),
            ("/approach/goal", "foxglove.PoseInFrame"),
            ("/approach/fused_map", "foxglove.PointCloud"),
            ("/approach/outcome", "foxglove.Log"),
        ):
            sid = w.register_schema(name=schema, encoding="jsonschema", data=_schema(schema))
            channels[topic] = w.register_channel(
                topic=topic, message_encoding="json", schema_id=sid
            )

        def put(topic: str, t: float, msg: dict[str, Any]) -> None:
            ns = round(t * 1e9)
            stamp = {"sec": ns // 10**9, "nsec": ns % 10**9}
            body = json.dumps({"timestamp": stamp, **msg}, allow_nan=False).encode()
            w.add_message(channels[topic], log_time=ns, data=body, publish_time=ns)

        for k, (x, y) in enumerate(true):
            o = odom[min(k, len(odom) - 1)]
            heading = math.atan2(rec["target_odom"][1] - o[1], rec["target_odom"][0] - o[0])
            put("/approach/base", steps[k], {"frame_id": "world", "pose": _pose(x, y, heading)})
            put("/approach/odom", steps[k], {"frame_id": "world", "pose": _pose(*o)})
        end = float(steps[-1])
        put(
            "/approach/path",
            end,
            {"frame_id": "world", "poses": [_pose(x, y, 0.0) for x, y in true]},
        )
        looks = [_pose(*look["true"]) for look in rec["looks"]]
        put("/approach/looks", end, {"frame_id": "world", "poses": looks})
        if rec.get("goal"):
            put("/approach/goal", end, {"frame_id": "world", "pose": _pose(*rec["goal"])})
        xy = np.asarray(cap["fused"]["xy"], np.float32).reshape(-1, 2)
        pts = np.column_stack(
            [xy, np.zeros(len(xy), np.float32), np.asarray(cap["fused"]["value"], np.float32)]
        ).astype(np.float32)
        import base64

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
        verdict = "success" if rec["success"] else f"failure: {rec['stage']}"
        message = f"{rec['method']} ({rec['policy']}), {rec['start']} start: {verdict}"
        put(
            "/approach/outcome",
            end,
            {"level": 2, "message": message, "name": "approach", "file": "", "line": 0},
        )
        w.finish()
