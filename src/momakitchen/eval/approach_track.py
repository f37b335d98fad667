"""Running the approach track over a dataset split: starts, baselines' goals, every
method's episodes per configuration, and a resumable run (see
:mod:`momakitchen.eval.approach` for one episode)."""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from momakitchen.errors import MomaError
from momakitchen.eval.approach import (
    BASELINES,
    STARTS,
    ApproachConfig,
    Context,
    ModelPerceiver,
    run_episode,
)
from momakitchen.sim.motion import BaseState, FreeSpace, face

Pose = tuple[float, float, float]


# ------------------------------------------------------------------------------ starts
def near_start(ctx: Context, shard: Any, scene: Any) -> tuple[Pose, np.ndarray] | None:
    """The base pose and head of the view ``msr`` judges for the seed (None: none)."""
    from momakitchen.eval.msr import msr_view

    ep = msr_view(shard, scene, ctx.cfg.index, ctx.config.seed)
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
    front = _front_cells(ctx)
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


def _front_cells(ctx: Context) -> np.ndarray:
    """Free cells within the arm's reach in front of the target, nearest first."""
    rel = ctx.free.cells - ctx.anchor[:2]
    d = np.hypot(rel[:, 0], rel[:, 1])
    ok = ctx.free.free & (d <= ctx.spec.reach) & (rel[:, 1] > 0)
    idx = np.flatnonzero(ok)
    return idx[np.argsort(d[idx], kind="stable")]


# --------------------------------------------------------------------------- baselines
def baseline_goal(ctx: Context, name: str) -> Callable[[BaseState], Pose | None]:
    """A baseline's goal from where the base is (odometry frame = world at the start):
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
        candidates = ctx.free.cells[_front_cells(ctx)]
    else:  # as msr's: any floor cell within reach, where the base may not even fit
        rel = ctx.free.cells - anchor[:2]
        within = np.flatnonzero(
            (np.hypot(rel[:, 0], rel[:, 1]) <= ctx.spec.reach) & (rel[:, 1] > 0)
        )
        rng = np.random.default_rng([ctx.config.seed, ctx.cfg.scene_id, ctx.cfg.index, 1])
        pick = ctx.free.cells[within[rng.integers(len(within))]] if len(within) else None

        def random_goal(state: BaseState) -> Pose | None:
            if pick is None:
                return None
            return (float(pick[0]), float(pick[1]), face(pick, anchor))

        return random_goal

    def goal(state: BaseState) -> Pose | None:
        reach = ctx.free.reachable(state.odom[:2])
        for x, y in candidates:
            if reach(x, y):
                return (float(x), float(y), face((x, y), anchor))
        return None

    return goal


# ----------------------------------------------------------------------- configuration
def configuration_context(
    scene: Any, ci: int, labels: Any, gen: Any, world: Any, runner: Any, config: ApproachConfig
) -> Context:
    from momakitchen.robots.spec import get_robot_spec

    cfg = scene.configurations[ci]
    spec = get_robot_spec(cfg.robot)
    free = FreeSpace(scene.layout, cfg, spec.footprint, config.motion)
    successes = labels.trial_positions[labels.trial_stages == 0]
    return Context(
        scene, cfg, labels, gen, world, runner, free, spec, config, successes, labels.feasible
    )


def run_configuration(
    shard: Any,
    scene: Any,
    ci: int,
    gen: Any,
    methods: dict[str, Any],
    baselines: Sequence[str],
    config: ApproachConfig,
) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """Every (start, method, policy) episode of configuration ``ci``: the records, and the
    starts that could not be placed (``skipped``)."""
    from momakitchen.data.manifest import target_category
    from momakitchen.sim.trials import TrialRunner
    from momakitchen.sim.world import World

    labels = shard.configuration(ci)
    cfg = scene.configurations[ci]
    records, skipped = [], []
    with World(scene.layout) as world:
        world.load_configuration(cfg)
        runner = TrialRunner(world, cfg.robot, gen.trial)
        try:
            ctx = configuration_context(scene, ci, labels, gen, world, runner, config)
            for start_index, start_kind in enumerate(STARTS):
                if start_kind not in config.starts:
                    continue
                placed = near_start(ctx, shard, scene) if start_kind == "near" else far_start(ctx)
                if placed is None:
                    skipped.append(
                        {"scene_id": cfg.scene_id, "config_index": ci, "start": start_kind}
                    )
                    continue
                start, head = placed
                shortest = _shortest(ctx, start)
                head_fields = {
                    "scene_id": cfg.scene_id,
                    "config_index": ci,
                    "robot": cfg.robot,
                    "target": labels.target,
                    "category": target_category(labels.target),
                    "feasible": bool(labels.feasible),
                    "start": start_kind,
                    "start_pose": [round(v, 4) for v in start],
                    "start_distance": round(
                        float(np.hypot(*(np.asarray(start[:2]) - ctx.anchor[:2]))), 3
                    ),
                    "shortest": None if math.isinf(shortest) else round(shortest, 3),
                }
                for name, perceiver in methods.items():
                    first = None
                    for policy in config.policies:
                        rec, look = run_episode(
                            ctx,
                            start,
                            head,
                            start_index,
                            name,
                            policy,
                            perceiver=perceiver,
                            first_look=first,
                        )
                        first = first or look
                        records.append(_finish(head_fields, rec, shortest))
                for name in baselines:
                    rec, _ = run_episode(
                        ctx, start, head, start_index, name, "-", goal_of=baseline_goal(ctx, name)
                    )
                    records.append(_finish(head_fields, rec, shortest))
        finally:
            runner.close()
    return records, skipped


def _shortest(ctx: Context, start: Pose) -> float:
    """L*: the shortest collision-free path (m) from the start to a successful grid cell
    (inf for an infeasible configuration)."""
    if not len(ctx.successes):
        return math.inf
    lengths = ctx.free.shortest(start[:2])
    best = min(float(lengths[ctx.free.index(*p)]) for p in ctx.successes)
    if math.isinf(best):  # success cells the floor plan calls blocked: the straight line
        best = float(np.min(np.hypot(*(ctx.successes - np.asarray(start[:2])).T)))
    return best


def _finish(head: dict[str, Any], rec: dict[str, Any], shortest: float) -> dict[str, Any]:
    out = {**head, **rec}
    driven = rec["driven"]
    spl = 0.0
    if rec["success"] and not math.isinf(shortest):
        spl = shortest / max(driven, shortest) if max(driven, shortest) > 0 else 1.0
    out["spl"] = round(spl, 4)
    out["n_looks"] = len(rec["looks"])
    return out


# --------------------------------------------------------------------------------- run
def load_methods(
    checkpoints: Sequence[str | os.PathLike], servers: Sequence[str], preprocessing: Any, root: Path
) -> dict[str, Any]:
    """The model methods: trained runs (or plug-ins; ``bundled``: the bundled model) and
    servers, by unique name."""
    from momakitchen.deploy.client import ServerPerceiver
    from momakitchen.train.checkpoint import check_preprocessing, load_checkpoint

    methods: dict[str, Any] = {}
    for run_dir in checkpoints:
        if str(run_dir) == "bundled":
            from momakitchen.train.checkpoint import default_checkpoint

            run_dir = default_checkpoint()
        run = load_checkpoint(Path(run_dir))
        check_preprocessing(run, preprocessing, f"dataset {str(root)!r}")
        name = run.config.model
        if name in methods:
            name = f"{name}:{Path(run_dir).name}"
        methods[name] = ModelPerceiver(run, name)
    for url in servers:
        server = ServerPerceiver(url)  # reachable and answering, before any work
        name = server.name if server.name not in methods else f"{server.name}@{url}"
        methods[name] = server
    return methods


def run_approach(
    data: str | os.PathLike,
    checkpoints: Sequence[str | os.PathLike] = (),
    baselines: Sequence[str] = (),
    servers: Sequence[str] = (),
    config: ApproachConfig | None = None,
    progress: bool = False,
    resume: str | os.PathLike | None = None,
    methods: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """The approach track on a dataset split (no method given: the bundled model).

    ``methods``: model methods already loaded (:func:`load_methods`), instead of
    ``checkpoints`` and ``servers``. ``resume``: a JSON-lines file of the configurations
    done so far (one line each, appended as they finish); a run started again with the
    same file and settings skips them, so a killed run loses at most the configuration it
    was in.

    Returns ``{"config", "dataset", "methods", "records", "skipped"}`` (records: one per
    episode; summaries: :func:`momakitchen.eval.approach_report.summarize`).
    """
    from tqdm.auto import tqdm

    from momakitchen.data.config import Preprocessing
    from momakitchen.data.integrity import check_shard_files
    from momakitchen.eval.msr import (
        dataset_generation,
        judged_configurations,
        rebuilt_configurations,
    )

    config = config or ApproachConfig()
    unknown = [b for b in baselines if b not in BASELINES]
    if unknown:
        raise MomaError(f"unknown method {unknown[0]!r}; baselines: {', '.join(BASELINES)}")
    if len(set(baselines)) != len(baselines):
        raise MomaError(f"method named twice: {list(baselines)}")
    if not checkpoints and not baselines and not servers and methods is None:
        from momakitchen.train.checkpoint import default_checkpoint

        checkpoints = [default_checkpoint()]
    root = Path(data)
    manifest, gen = dataset_generation(root)
    if methods is None:
        preprocessing = Preprocessing(gen.cloud, gen.camera.max_depth)
        methods = load_methods(checkpoints, servers, preprocessing, root)
    todo = judged_configurations(root, manifest, config.split, config.max_configs)
    todo = part_of(todo, *config.part)
    check_shard_files(root, manifest, {sid for sid, _, _ in todo})
    settings = {
        "config": config.to_dict(),
        "dataset": str(root.resolve()),
        "methods": [*methods, *baselines],
    }
    done = _load_resume(Path(resume), settings) if resume else {}
    records: list[dict[str, Any]] = []
    skipped: list[dict[str, Any]] = []
    for key in done:
        records += done[key]["records"]
        skipped += done[key]["skipped"]
    left = [t for t in todo if (t[0], t[1]) not in done]
    bar = tqdm(
        total=len(todo),
        initial=len(todo) - len(left),
        desc="approach",
        unit="config",
        disable=not progress,
    )
    try:
        for scene, shard, ci in rebuilt_configurations(root, left, gen.scene):
            recs, skip = run_configuration(shard, scene, ci, gen, methods, baselines, config)
            records += recs
            skipped += skip
            if resume:
                _append_resume(Path(resume), scene.layout.scene_id, ci, recs, skip)
            bar.update(1)
            first = [r["success"] for r in records if r["method"] == records[0]["method"]]
            bar.set_postfix(success=f"{np.mean(first):.2f}" if first else "-", refresh=False)
    finally:
        bar.close()
    order = {(sid, ci): k for k, (sid, ci, _) in enumerate(todo)}
    records.sort(key=lambda r: order[(r["scene_id"], r["config_index"])])
    return {
        "dataset": str(root),
        "config": config.to_dict(),
        "methods": [*methods, *baselines],
        "configurations": len(todo),
        "records": records,
        "skipped": skipped,
    }


def part_of(todo: list[tuple[int, int, str]], k: int, n: int) -> list[tuple[int, int, str]]:
    """Part ``k`` of ``n`` of ``todo``: the configurations of every n-th scene, from the
    k-th (scenes interleaved, so every part has scenes from the whole range); MomaError
    when it is empty."""
    scenes = sorted({sid for sid, _, _ in todo})
    mine = set(scenes[k - 1 :: n])
    part = [t for t in todo if t[0] in mine]
    if not part:
        raise MomaError(f"part {k}/{n} is empty: the split has only {len(scenes)} scenes")
    return part


def _load_resume(path: Path, settings: dict[str, Any]) -> dict[tuple[int, int], dict[str, Any]]:
    """The configurations a resume file holds (its first line: the run's settings, which
    must equal these)."""
    if not path.exists():
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps({"settings": settings}, allow_nan=False) + "\n")
        return {}
    lines = path.read_text().splitlines()
    try:
        head = json.loads(lines[0])["settings"] if lines else None
    except (json.JSONDecodeError, KeyError, TypeError):
        head = None
    if head != json.loads(json.dumps(settings)):
        raise MomaError(
            f"resume file {str(path)!r} was written by a run with other settings, methods or "
            "dataset; delete it or run with the same ones"
        )
    done = {}
    for k, line in enumerate(lines[1:], 1):
        try:
            row = json.loads(line)
            done[(int(row["scene_id"]), int(row["config_index"]))] = row
        except (json.JSONDecodeError, KeyError, TypeError, ValueError):
            # A line cut by a kill: keep the lines before it, run the rest again.
            from momakitchen.fileio import atomic_write_text

            atomic_write_text(path, "\n".join(lines[:k]) + "\n")
            break
    return done


def _append_resume(path: Path, sid: int, ci: int, records: list, skipped: list) -> None:
    row = {"scene_id": sid, "config_index": ci, "records": records, "skipped": skipped}
    with open(path, "a") as f:
        f.write(json.dumps(row, allow_nan=False) + "\n")
        f.flush()
        os.fsync(f.fileno())
