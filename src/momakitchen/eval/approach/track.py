"""Running the approach track over a dataset split: starts, baselines' goals, every
method's episodes per configuration, and a resumable run (see
:mod:`momakitchen.eval.approach.episode` for one episode)."""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from momakitchen.errors import MomaError
from momakitchen.eval.approach.baselines import baseline_goal
from momakitchen.eval.approach.config import STARTS, ApproachConfig
from momakitchen.eval.approach.episode import (
    ClassicalPerceiver,
    Context,
    Episode,
    ModelPerceiver,
    Pose,
)
from momakitchen.eval.approach.records import ApproachRecord, StartRecord, shortest_or_none
from momakitchen.eval.approach.starts import far_start, near_start
from momakitchen.eval.methods import CLASSICAL, METHODS
from momakitchen.sim.motion import FreeSpace


# ----------------------------------------------------------------------- configuration
@contextmanager
def opened_configuration(
    scene: Any, shard: Any, ci: int, gen: Any, config: ApproachConfig
) -> Iterator[Context]:
    """Configuration ``ci`` of ``scene`` loaded in a world with its trial runner, as the
    :class:`Context` its episodes share; closed on exit."""
    from momakitchen.robots.spec import get_robot_spec
    from momakitchen.sim.trials import TrialRunner
    from momakitchen.sim.world import World

    cfg = scene.configurations[ci]
    labels = shard.configuration(ci)
    with World(scene.layout) as world:
        world.load_configuration(cfg)
        runner = TrialRunner(world, cfg.robot, gen.trial)
        try:
            spec = get_robot_spec(cfg.robot)
            free = FreeSpace(scene.layout, cfg, spec.footprint, config.motion)
            known = free
            if config.map == "static":  # the prior map: the room without the obstacles
                known = FreeSpace(scene.layout, cfg, spec.footprint, config.motion, False)
            successes = labels.trial_positions[labels.trial_stages == 0]
            yield Context(
                scene,
                cfg,
                labels,
                gen,
                world,
                runner,
                free,
                known,
                spec,
                config,
                successes,
                labels.feasible,
            )
        finally:
            runner.close()


def placed_start(ctx: Context, kind: str, shard: Any) -> tuple[Pose, np.ndarray] | None:
    """The start pose and head of a ``near`` or ``far`` start (None: none fits)."""
    return near_start(ctx, shard, ctx.scene) if kind == "near" else far_start(ctx)


def run_configuration(
    shard: Any,
    scene: Any,
    ci: int,
    gen: Any,
    methods: dict[str, Any],
    baselines: Sequence[str],
    config: ApproachConfig,
) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """Every (start, method, policy) episode of configuration ``ci``: the records (as
    JSON rows), and the starts that could not be placed (``skipped``)."""
    from momakitchen.data.manifest import target_category

    records: list[ApproachRecord] = []
    skipped = []
    with opened_configuration(scene, shard, ci, gen, config) as ctx:
        cfg, labels = ctx.cfg, ctx.labels
        for start_index, start_kind in enumerate(STARTS):
            if start_kind not in config.starts:
                continue
            placed = placed_start(ctx, start_kind, shard)
            if placed is None:
                skipped.append({"scene_id": cfg.scene_id, "config_index": ci, "start": start_kind})
                continue
            start, head = placed
            shortest = _shortest(ctx, start)
            start_record = StartRecord(
                scene_id=cfg.scene_id,
                config_index=ci,
                robot=cfg.robot,
                target=labels.target,
                category=target_category(labels.target),
                feasible=bool(labels.feasible),
                start=start_kind,
                start_pose=[round(v, 4) for v in start],
                start_distance=round(float(np.hypot(*(np.asarray(start[:2]) - ctx.anchor[:2]))), 3),
                shortest=shortest_or_none(shortest),
                articulated=cfg.target.is_articulated,
                obstacles_near=_obstacles_near(cfg),
                target_height=round(float(ctx.anchor[2]), 3),
                reach=float(ctx.spec.reach),
                mount=round(float(cfg.mount), 3),
            )
            for name, perceiver in methods.items():
                first = None
                for policy in config.policies:
                    episode = Episode(
                        ctx,
                        start,
                        head,
                        start_index,
                        name,
                        policy,
                        perceiver=perceiver,
                        first_look=first,
                    )
                    rec = episode.run()
                    first = first or episode.first
                    records.append(ApproachRecord.of(start_record, rec, shortest))
            for name in baselines:
                goal_of = baseline_goal(ctx, name)
                rec = Episode(ctx, start, head, start_index, name, "-", goal_of=goal_of).run()
                records.append(ApproachRecord.of(start_record, rec, shortest))
    return [r.to_dict() for r in records], skipped


def _obstacles_near(cfg: Any, radius: float = 1.0) -> int:
    """The generated obstacles whose footprint's centre lies within ``radius`` m of the
    target's floor projection."""
    anchor = np.asarray(cfg.target.anchor[:2], float)
    centres = [(f.x, f.y) for f in (o.footprint() for o in cfg.obstacles)]
    return int(sum(np.hypot(*(np.asarray(c) - anchor)) <= radius for c in centres))


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


# --------------------------------------------------------------------------------- run
def load_methods(
    checkpoints: Sequence[str | os.PathLike], servers: Sequence[str], preprocessing: Any, root: Path
) -> dict[str, Any]:
    """The model methods: trained runs (or plug-ins; ``bundled``: the bundled model) and
    servers, by unique name."""
    from momakitchen.deploy.client import ServerPerceiver
    from momakitchen.train.checkpoint import check_preprocessing, load_checkpoint, run_label

    methods: dict[str, Any] = {}
    for run_dir in checkpoints:
        run = load_checkpoint(run_dir)
        check_preprocessing(run, preprocessing, f"dataset {str(root)!r}")
        name = run_label(run)
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
    episode; summaries: :func:`momakitchen.eval.approach.report.summarize`).
    """
    from tqdm.auto import tqdm

    from momakitchen.data.config import Preprocessing
    from momakitchen.data.integrity import check_shard_files
    from momakitchen.data.reader import (
        dataset_generation,
        judged_configurations,
        rebuilt_configurations,
    )

    config = config or ApproachConfig()
    unknown = [b for b in baselines if b not in METHODS]
    if unknown:
        raise MomaError(f"unknown method {unknown[0]!r}; methods: {', '.join(METHODS)}")
    if len(set(baselines)) != len(baselines):
        raise MomaError(f"method named twice: {list(baselines)}")
    classical = [b for b in baselines if b in CLASSICAL]
    baselines = [b for b in baselines if b not in CLASSICAL]
    if not checkpoints and not baselines and not classical and not servers and methods is None:
        from momakitchen.train.checkpoint import default_checkpoint

        checkpoints = [default_checkpoint()]
    root = Path(data)
    manifest, gen = dataset_generation(root)
    if methods is None:
        preprocessing = Preprocessing(gen.cloud, gen.camera.max_depth)
        methods = load_methods(checkpoints, servers, preprocessing, root)
    # Classical methods look as models do: what they take is one frame, too.
    methods = {**methods, **{name: ClassicalPerceiver(name) for name in classical}}
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
            # The first row's success so far, named (a pool over rows would say nothing).
            head = (records[0]["method"], records[0]["policy"]) if records else None
            first = [r["success"] for r in records if (r["method"], r["policy"]) == head]
            if head is not None:
                label = head[0] if head[1] == "-" else f"{head[0]} ({head[1]})"
                bar.set_postfix({f"{label} success": f"{np.mean(first):.2f}"}, refresh=False)
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
