"""Where an approach starts: the view ``msr`` judges (near) or a far pose that sees the
target, the same for every method."""

from __future__ import annotations

from typing import Any

import numpy as np

from momakitchen.eval.approach.episode import Context, Pose
from momakitchen.sim.motion import FreeSpace, face


def near_start(ctx: Context, shard: Any, scene: Any) -> tuple[Pose, np.ndarray] | None:
    """The base pose and head of the view ``msr`` judges for the seed (None: none)."""
    from momakitchen.data.reader import judged_view

    ep = judged_view(shard, scene, ctx.cfg.index, ctx.config.seed)
    if ep is None:
        return None
    episode = shard.episode(ctx.cfg.index, ep)
    pose = tuple(float(v) for v in episode.base_pose)
    return (pose[0], pose[1], pose[2]), np.asarray(episode.camera_to_base, np.float64)


def far_start(ctx: Context) -> tuple[Pose, np.ndarray] | None:
    """The farthest free pose ``far_range`` from the target (as the room allows: the
    farthest below the range when none lies in it), within ``far_angle`` of the
    direction the target faces (+y, away from the wall), connected to the floor in
    front of the target and seeing it (a render shows at least ``min_target_pixels``
    of it). The same for every method."""
    free, anchor = ctx.free, ctx.anchor
    lo, hi = ctx.config.far_range
    rel = free.cells - anchor[:2]
    dist = np.hypot(rel[:, 0], rel[:, 1])
    angle = np.degrees(np.abs(np.arctan2(rel[:, 0], rel[:, 1])))  # from +y
    ok = free.free & (angle <= ctx.config.far_angle) & (dist <= hi) & (dist >= 1.5)
    front = front_cells(ctx)
    if not len(front):
        return None
    # Farthest first; within the range by distance, below it too ("as the room allows").
    order = np.flatnonzero(ok)[np.argsort(-dist[ok], kind="stable")]
    # Connected to one of the nearest front cells: one labelling of the free floor, not a
    # path search per candidate.
    reaches_front = np.isin(free.components, free.components[front[:50]])
    tried = 0
    for i in order:
        if dist[i] < lo and tried >= 4:  # below the range: a few more, then give up
            break
        if not reaches_front[i]:
            continue
        x, y = (float(v) for v in free.cells[i])
        pose = (x, y, face((x, y), anchor))
        head = ctx.head(pose, anchor)
        tried += 1
        frame = ctx.render(pose, head)
        if int(frame.target_mask.sum()) >= ctx.gen.views.min_target_pixels:
            return pose, head
        if tried >= 12:
            break
    return None


def front_cells(ctx: Context, free: FreeSpace | None = None) -> np.ndarray:
    """Cells of ``free`` (default: the room's true free space) within the arm's reach in
    front of the target, nearest first."""
    free = free or ctx.free
    rel = free.cells - ctx.anchor[:2]
    d = np.hypot(rel[:, 0], rel[:, 1])
    ok = free.free & (d <= ctx.spec.reach) & (rel[:, 1] > 0)
    idx = np.flatnonzero(ok)
    return idx[np.argsort(d[idx], kind="stable")]
