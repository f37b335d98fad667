"""The approach track's baselines: goals from the ground truth (``oracle``) or from the
room's geometry (``nearest``, ``random``), driven as a model's are."""

from __future__ import annotations

import numpy as np

from momakitchen.eval.approach.episode import Context, GoalOf, Pose
from momakitchen.eval.approach.starts import front_cells
from momakitchen.sim.motion import BaseState, FreeSpace, face


def baseline_goal(ctx: Context, name: str) -> GoalOf:
    """A baseline's goal from where the base is (odometry frame = world at the start) and
    what its costmap knows (only cells it can reach there count):
    ``oracle`` the successful grid cell with the highest ground-truth map value (the
    first reachable one), ``nearest`` the reachable free cell nearest the target,
    ``random`` a floor cell drawn within the arm's reach in front of the target, free or
    not, as ``msr``'s random (the paper's Random): one the base cannot reach is a
    failure."""
    from momakitchen.sim.labels import dense_map

    anchor = ctx.anchor
    if name == "oracle":
        pts = ctx.successes
        if len(pts):
            outcomes = ctx.labels.trial_outcomes.astype(np.float64)
            values = dense_map(ctx.labels.trial_positions, outcomes, pts, ctx.gen.dense)
            candidates = pts[np.argsort(-values, kind="stable")]
        else:
            candidates = np.zeros((0, 2))
    elif name == "nearest":
        candidates = ctx.known.cells[front_cells(ctx, ctx.known)]
    else:  # as msr's: any floor cell within reach, where the base may not even fit
        rel = ctx.free.cells - anchor[:2]
        within = np.flatnonzero(
            (np.hypot(rel[:, 0], rel[:, 1]) <= ctx.spec.reach) & (rel[:, 1] > 0)
        )
        rng = np.random.default_rng([ctx.config.seed, ctx.cfg.scene_id, ctx.cfg.index, 1])
        pick = ctx.free.cells[within[rng.integers(len(within))]] if len(within) else None

        def random_goal(state: BaseState, costmap: FreeSpace) -> Pose | None:
            if pick is None:
                return None
            return (float(pick[0]), float(pick[1]), face(pick, anchor))

        return random_goal

    def goal(state: BaseState, costmap: FreeSpace) -> Pose | None:
        reach = costmap.reachable(state.odom[:2])
        for x, y in candidates:
            if reach(x, y):
                return (float(x), float(y), face((x, y), anchor))
        return None

    return goal
