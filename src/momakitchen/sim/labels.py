"""Affordance labels: trials on the semicircle grid (sparse) and the dense floor map.

Sparse labels are trial outcomes at the grid positions of the sampling semicircle (radius
= the robot's reach, in front of the target). The dense map spreads them over arbitrary
floor points: each floor point is associated with the trial positions within ``theta``
of it, and takes the Gaussian-weighted mean outcome of its ``k`` nearest associated
positions (weights ``exp(-d^2 / (2 sigma^2))``); a point with no trial within ``theta``
gets 0. Values lie in [0, 1].
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from momakitchen.bullet import p
from momakitchen.errors import MomaError
from momakitchen.frames import base_to_world_xy, float3, world_to_base
from momakitchen.robots import get_robot_spec
from momakitchen.scene.configuration import Configuration, base_fits
from momakitchen.scene.geometry import semicircle_grid
from momakitchen.scene.layout import Layout
from momakitchen.sim.config import STAGE_NAMES, DenseMapConfig, Stage, TrialConfig
from momakitchen.sim.trials import TrialRunner
from momakitchen.sim.world import World


def dense_map(
    positions: np.ndarray,
    outcomes: np.ndarray,
    query: np.ndarray,
    config: DenseMapConfig | None = None,
) -> np.ndarray:
    """Interpolate trial outcomes onto floor points.

    Shapes: ``positions`` (P, 2) trial positions, ``outcomes`` (P,) in {0, 1} (or [0, 1]),
    ``query`` (M, 2) floor points in the same frame; returns (M,) float32 in [0, 1].
    """
    cfg = config or DenseMapConfig()
    positions = np.asarray(positions, float).reshape(-1, 2)
    outcomes = np.asarray(outcomes, float).reshape(-1)
    query = np.asarray(query, float).reshape(-1, 2)
    if len(positions) != len(outcomes):
        raise MomaError(f"{len(positions)} trial positions but {len(outcomes)} outcomes")
    values = np.zeros(len(query), dtype=np.float32)
    if len(positions) == 0 or len(query) == 0:
        return values
    k = min(cfg.k, len(positions))
    dist, idx = cKDTree(positions).query(query, k=k, distance_upper_bound=cfg.theta)
    dist, idx = dist.reshape(len(query), k), idx.reshape(len(query), k)
    valid = np.isfinite(dist)  # missing neighbours come back as inf / index P
    w = np.where(valid, np.exp(-np.square(np.where(valid, dist, 0.0)) / (2 * cfg.sigma**2)), 0)
    o = np.where(valid, outcomes[np.minimum(idx, len(outcomes) - 1)], 0.0)
    wsum = w.sum(axis=1)
    out = np.zeros(len(query))
    np.divide((w * o).sum(axis=1), wsum, out=out, where=wsum > 0)
    return np.clip(out, 0.0, 1.0).astype(np.float32)


def floor_affordance(
    labels: Labels,
    layout: Layout,
    cfg: Configuration,
    points: np.ndarray,
    base: Sequence[float],
    config: DenseMapConfig | None = None,
) -> np.ndarray:
    """The dense map of ``labels`` at floor points of a viewpoint, 0 where the base would
    not fit (facing the target) and outside the sampling area, whatever the interpolation
    says (:func:`standable`).

    Shapes: ``points`` (M, 2) in the base frame of the viewpoint ``base`` = (x, y, yaw)
    in the world; returns (M,) float32 in [0, 1].
    """
    values = dense_map(
        world_to_base(labels.positions, float3(base)), labels.outcomes, points, config
    )
    # The mask only matters where the map is positive (most floor points are 0).
    lit = np.flatnonzero(values > 0)
    keep = standable(layout, cfg, base_to_world_xy(points[lit], base))
    out = np.zeros(len(values), np.float32)
    out[lit] = np.where(keep, values[lit], np.float32(0.0))
    return out


def standable(layout: Layout, cfg: Configuration, points: np.ndarray) -> np.ndarray:
    """Where a dense map may be positive: inside the sampling area (within the robot's
    reach of the target, where the trials ran: beyond it the interpolation would only
    extend the outermost successes, with no trial to say otherwise) and where the base,
    facing the target, fits by the floor plan.

    Shapes: ``points`` (M, 2) world xy; returns (M,) bool.
    """
    pts = np.asarray(points, np.float64).reshape(-1, 2)
    inside = in_sampling_area(cfg, pts)
    fits = np.zeros(len(pts), bool)
    fits[inside] = base_fits(layout, cfg, pts[inside], get_robot_spec(cfg.robot).footprint)
    return fits


def in_sampling_area(cfg: Configuration, points: np.ndarray) -> np.ndarray:
    """Where the trials ran: within the robot's reach of the target.

    Shapes: ``points`` (M, 2) world xy; returns (M,) bool.
    """
    offset = np.asarray(points, np.float64).reshape(-1, 2) - np.asarray(cfg.target.anchor[:2])
    return np.hypot(offset[:, 0], offset[:, 1]) <= get_robot_spec(cfg.robot).reach + 1e-9


@dataclass(frozen=True)
class Labels:
    """Sparse labels of one configuration.

    Shapes: ``positions`` (P, 2) world xy of the trial grid; ``yaws`` (P,) base yaw (facing
    the target); ``stages`` (P,) :class:`Stage` codes (0 = success); ``moved`` (P,) object
    rise (m) or joint opening (rad or m) reached in physics (0 where no physics ran).
    ``seconds`` splits the wall time: check, ik, physics, total. ``grasps`` (P,) names the
    grasp candidate each trial executed ("" where no plan reached physics): which one
    succeeded, which one failed in execution. ``mount_height`` is the arm's mount height
    in metres where the configuration drew one (None: the robot's own). ``why`` (P,) says
    what stopped each failed trial (``TrialResult.why``; empty tuples where nothing is
    known): diagnosis only, never stored in a dataset.
    """

    scene_id: int
    config_index: int
    robot: str
    target: str
    anchor: tuple[float, float, float]
    grid_spacing: float
    positions: np.ndarray
    yaws: np.ndarray
    stages: np.ndarray
    moved: np.ndarray
    seconds: dict[str, float]
    grasps: tuple[str, ...] = ()
    mount_height: float | None = None
    why: tuple[tuple[str, ...], ...] = ()

    @property
    def outcomes(self) -> np.ndarray:
        """(P,) uint8: 1 where the trial succeeded."""
        return (self.stages == Stage.SUCCESS).astype(np.uint8)

    def stage_counts(self) -> dict[str, int]:
        return {
            name: int((self.stages == s).sum()) for s, name in zip(Stage, STAGE_NAMES, strict=True)
        }

    def summary(self) -> dict:
        n = len(self.stages)
        physics = int(
            ((self.stages == Stage.SUCCESS) | (self.stages == Stage.EXECUTION_FAILED)).sum()
        )
        return {
            "scene_id": self.scene_id,
            "config_index": self.config_index,
            "robot": self.robot,
            **({} if self.mount_height is None else {"mount_height": self.mount_height}),
            "target": self.target,
            "anchor": list(self.anchor),
            "positions": n,
            "grid_spacing": self.grid_spacing,
            "successes": int(self.outcomes.sum()),
            "success_rate": float(self.outcomes.mean()) if n else 0.0,
            "physics_trials": physics,
            "stages": self.stage_counts(),
            "grasps": self.grasp_counts(),
            "seconds": {k: round(v, 4) for k, v in self.seconds.items()},
        }

    def grasp_counts(self) -> dict[str, dict[str, int]]:
        """Per grasp candidate executed in physics: how many trials succeeded and failed."""
        out: dict[str, dict[str, int]] = {}
        for name, stage in zip(self.grasps, self.stages, strict=False):
            if name:
                key = "success" if stage == Stage.SUCCESS else "execution_failed"
                counts = out.setdefault(name, {"success": 0, "execution_failed": 0})
                counts[key] += 1
        return out


def target_name(world: World) -> str:
    """Target category, with the part for articulated targets (e.g. ``fridge/door``)."""
    t = world.target
    return t.category if t.part == "object" else f"{t.category}/{t.part}"


def set_target_dynamics(
    world: World, mass: float | None = None, friction: float | None = None
) -> None:
    """Change the target's mass (kg) and/or lateral friction coefficient (what-if studies:
    a 50 kg bottle cannot be lifted, a frictionless one slips out of the fingers)."""
    t = world.target
    kwargs = {}
    if mass is not None:
        if not mass > 0:
            raise MomaError(f"target mass must be > 0 kg, got {mass}")
        kwargs["mass"] = float(mass)
    if friction is not None:
        if not friction >= 0:
            raise MomaError(f"target friction must be >= 0, got {friction}")
        kwargs["lateralFriction"] = float(friction)
    if kwargs:
        p.changeDynamics(t.body_id, t.link_index, physicsClientId=world.client, **kwargs)


def label_configuration(
    world: World,
    cfg: Configuration,
    *,
    trial_config: TrialConfig | None = None,
    grid_spacing: float = 0.1,
    target_mass: float | None = None,
    target_friction: float | None = None,
    progress: Callable[[int, int], None] | None = None,
    diagnose: bool = False,
) -> Labels:
    """Run the trials of ``cfg`` on its sampling grid and return the sparse labels.

    The world is reset to ``cfg`` first (``World.load_configuration``), the robot of the
    configuration is loaded for the trials and removed afterwards. ``diagnose`` also
    says which joints stop IK where it fails (``Labels.why``; one more IK solve there
    after the last trial, the same outcomes).
    """
    t0 = time.perf_counter()
    world.load_configuration(cfg)
    set_target_dynamics(world, target_mass, target_friction)
    spec = get_robot_spec(cfg.robot)
    grid = semicircle_grid(cfg.target.anchor[:2], spec.reach, grid_spacing)
    runner = TrialRunner(world, cfg.robot, trial_config, diagnose=diagnose)
    results = []
    try:
        for i, (x, y) in enumerate(grid):
            results.append(runner.run(float(x), float(y)))
            if progress is not None:
                progress(i + 1, len(grid))
        if diagnose:  # after every trial, which its IK must not come between
            results = [
                runner.explain_ik(float(x), float(y), r)
                for (x, y), r in zip(grid, results, strict=True)
            ]
    finally:
        runner.close()
    ax, ay = cfg.target.anchor[:2]
    seconds = {
        "check": sum(r.t_check for r in results),
        "ik": sum(r.t_ik for r in results),
        "physics": sum(r.t_physics for r in results),
        "total": time.perf_counter() - t0,
    }
    return Labels(
        scene_id=cfg.scene_id,
        config_index=cfg.index,
        robot=cfg.robot,
        target=target_name(world),
        anchor=float3(cfg.target.anchor),
        grid_spacing=grid_spacing,
        positions=grid.astype(np.float64),
        yaws=np.arctan2(ay - grid[:, 1], ax - grid[:, 0]),
        stages=np.array([int(r.stage) for r in results], dtype=np.uint8),
        moved=np.array([r.moved for r in results], dtype=np.float32),
        seconds=seconds,
        grasps=tuple(r.grasp for r in results),
        mount_height=cfg.mount_height,
        why=tuple(r.why for r in results),
    )


@dataclass(frozen=True)
class Rejection:
    """A stage that rejected most of the positions that reached it.

    Attributes:
        stage: the stage's name (``STAGE_NAMES``).
        rejected: positions that failed at this stage.
        reached: positions that got as far as this stage (passed every earlier one).
        causes: ``(cause, positions)`` pairs, most frequent first: colliding pairs
            (``"LINK with OTHER"``) or what went wrong in execution.
    """

    stage: str
    rejected: int
    reached: int
    causes: tuple[tuple[str, int], ...]

    def line(self, top: int = 2) -> str:
        """One line, e.g. ``arm_collision rejected 34 of 41 positions: most often
        panda_link0 with mobile_base (29)``."""
        text = f"{self.stage} rejected {self.rejected} of {self.reached} positions"
        if self.causes:
            shown = ", then ".join(f"{c} ({n})" for c, n in self.causes[:top])
            text += f": most often {shown}"
        return text


def rejections(labels: Labels, share: float = 0.5) -> list[Rejection]:
    """The stages that rejected more than ``share`` of the positions reaching them, in
    trial order, with their most frequent causes (each counted once per position)."""
    stages = np.asarray(labels.stages)
    out = []
    for stage in list(Stage)[1:]:  # trial order: the enum's (base collision first)
        # Stage codes follow the trial's order: a position reached ``stage`` when it
        # succeeded or failed there or later.
        reached = int(((stages == Stage.SUCCESS) | (stages >= stage)).sum())
        rejected = int((stages == stage).sum())
        if rejected == 0 or rejected <= share * reached:
            continue
        counts: dict[str, int] = {}
        for code, why in zip(stages, labels.why, strict=False):
            if code == stage:
                for cause in set(why):
                    counts[cause] = counts.get(cause, 0) + 1
        causes = tuple(sorted(counts.items(), key=lambda kv: (-kv[1], kv[0])))
        out.append(Rejection(STAGE_NAMES[stage], rejected, reached, causes))
    return out
