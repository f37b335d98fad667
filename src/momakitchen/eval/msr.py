"""Closed-loop manipulation success rate (MSR, docs/DESIGN.md §3.7).

For each configuration of a split, the world is rebuilt from ``(scene_id, configuration
index)`` and the dataset's generation config, one episode (view) of it is chosen, and each
method scores that episode's floor points. The best point (Top-1) and the best five
points at least ``min_spread`` apart (Top-5) are moved from the viewpoint's base frame to
the world; the robot's base is driven there facing the target and
:meth:`momakitchen.sim.trials.TrialRunner.run` (the labelling's trial, same code path)
executes the manipulation in physics. Top-1 MSR is the success rate of the first point,
Top-5 MSR the mean success over the (up to) five points.

Methods: a trained run (its prediction), a predictions file (a method run elsewhere, see
:mod:`momakitchen.eval.predictions`), ``oracle`` (the ground-truth map), ``random``
(random visible floor points within the arm's reach of the target: the paper's Random) and
``nearest`` (the visible floor points nearest to the target where the base fits:
conventional "go close" navigation).
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from momakitchen.data import manifest as mf
from momakitchen.data.manifest import SPLIT_CHOICES
from momakitchen.data.reader import (
    dataset_generation,
    judged_configurations,
    judged_view,
    rebuilt_configurations,
    view_record,
)
from momakitchen.data.shard import SceneShard
from momakitchen.data.torch_dataset import CLOUD_FIELDS, episode_sample
from momakitchen.errors import MomaError
from momakitchen.eval.methods import BASELINES, CLASSICAL, METHODS
from momakitchen.frames import base_to_world_xy
from momakitchen.models.inference import MC_SAMPLES, PICK_RADIUS, run_model, select_points


@dataclass(frozen=True)
class MsrConfig:
    """Settings of an MSR run.

    Attributes:
        top_k: points tried per method and configuration (Top-k MSR).
        min_spread: minimum distance (m) between the Top-k points.
        pick_radius: models and the oracle rank points by their map averaged over this
            radius (m; 0, the default: the raw map), as ``predict`` does.
        seed: seeds the episode chosen per configuration and the random baseline.
        split: configurations of which split (``test``, ``train`` or ``all``).
        max_configs: evaluate only the first this many configurations (0: all).
    """

    top_k: int = 5
    min_spread: float = 0.2
    pick_radius: float = PICK_RADIUS
    seed: int = 0
    split: str = "test"
    max_configs: int = 0

    def __post_init__(self) -> None:
        if not 1 <= self.top_k <= 20:
            raise MomaError(f"MsrConfig.top_k must be in [1, 20], got {self.top_k!r}")
        if not 0.0 <= self.min_spread <= 2.0:
            raise MomaError(f"MsrConfig.min_spread must be in [0, 2] m, got {self.min_spread!r}")
        if not 0.0 <= self.pick_radius <= 1.0:
            raise MomaError(f"MsrConfig.pick_radius must be in [0, 1] m, got {self.pick_radius!r}")
        if self.seed < 0:
            raise MomaError(f"MsrConfig.seed must be >= 0, got {self.seed!r}")
        if self.split not in SPLIT_CHOICES:
            raise MomaError(f"MsrConfig.split must be one of {SPLIT_CHOICES}, got {self.split!r}")
        if self.max_configs < 0:
            raise MomaError(f"MsrConfig.max_configs must be >= 0, got {self.max_configs!r}")


# The rates of a method's summary, as columns of every MSR table.
RATE_KEYS = ("top1", "topk", "top1_feasible", "topk_feasible")


def _rate(values: list[float]) -> float:
    return float(np.mean(values)) if values else 0.0


class _Checkpoint:
    """A trained run as an MSR method: its map of the episode's floor points and the
    map's MC-dropout standard deviation, exactly as ``predict`` computes them."""

    def __init__(self, run_dir: str | Path) -> None:
        from momakitchen.train.checkpoint import load_checkpoint, run_label

        self.run = load_checkpoint(run_dir)
        self.name = run_label(self.run)
        self.floor_context: int | None = self.run.config.num_floor

    def __call__(self, sample: dict[str, Any]) -> tuple[np.ndarray, np.ndarray | None]:
        _, pred, std = run_model(self.run, sample, MC_SAMPLES)
        return pred, std


class _PredictionsMethod:
    """A predictions file as an MSR method: its stored map of the episode (no
    uncertainty)."""

    def __init__(self, predictions: Any) -> None:
        self.predictions = predictions
        self.name: str = predictions.name
        self.floor_context: int | None = None

    def __call__(self, sample: dict[str, Any]) -> tuple[np.ndarray, np.ndarray | None]:
        ids = (sample["scene_id"], sample["config_index"], sample["episode_index"])
        scores = self.predictions.map(*ids)
        if len(scores) != len(sample["floor_xyz"]):
            raise MomaError(
                f"predictions file {str(self.predictions.path)!r}: episode "
                f"{'/'.join(map(str, ids))!r} has {len(scores)} values, the episode "
                f"{len(sample['floor_xyz'])} floor points"
            )
        return scores, None


class _ClassicalMethod:
    """A classical base-placement method (:func:`momakitchen.placement.place`) as an MSR
    method: it sees the judged view's frame (depth, masks, camera pose) and the robot at
    its mount, as a model's prediction would, and its map is read at the episode's floor
    points (the same render's floor: :func:`~momakitchen.placement.methods.map_at`)."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.floor_context: int | None = None

    def episode_scores(self, episode: Any, cfg: Any) -> np.ndarray:
        from momakitchen.data.episode import episode_frame
        from momakitchen.placement.methods import map_at, place_frame

        pred = place_frame(self.name, episode_frame(episode), cfg.robot, mount_height=cfg.mount)
        return map_at(pred, episode.floor_xyz[:, :2])


def run_configuration(
    shard: SceneShard,
    scene: Any,
    ci: int,
    gen: Any,
    models: dict[str, Any],
    names: Sequence[str],
    config: MsrConfig,
    after: Callable[[Any, dict[str, Any]], None] | None = None,
) -> dict[str, Any] | None:
    """Rebuild configuration ``ci`` of ``scene``, let every method choose its points on one
    episode and run their trials; the configuration's record (None: no usable episode).

    ``after(runner, context)``, if given, runs once the methods' trials are done, with the
    configuration's :class:`~momakitchen.sim.trials.TrialRunner` still loaded and
    ``context`` = ``{"record", "labels", "episode", "world_xy", "configuration"}`` (the label
    audit adds its own trials and fields to the record this way).
    """
    from momakitchen.frames import world_to_base
    from momakitchen.robots.spec import get_robot_spec
    from momakitchen.sim.trials import TrialRunner
    from momakitchen.sim.world import World

    sid = scene.layout.scene_id
    labels = shard.configuration(ci)
    ep = judged_view(shard, scene, ci, config.seed)
    if ep is None:
        return None
    cfg = scene.configurations[ci]
    episode = shard.episode(ci, ep)
    floor_xy = episode.floor_xyz[:, :2].astype(np.float64)
    world_xy = base_to_world_xy(floor_xy, episode.base_pose)
    target_xy = world_to_base(np.asarray([cfg.target.anchor[:2]]), episode.base_pose)[0]
    dist = np.hypot(*(floor_xy - target_xy).T)
    reach = get_robot_spec(cfg.robot).reach
    opens = cfg.target.is_articulated
    record = view_record(sid, ci, ep, labels, methods={})
    with World(scene.layout) as world:
        world.load_configuration(cfg)
        runner = TrialRunner(world, cfg.robot, gen.trial)
        # Trials do not depend on earlier ones (the world is restored before each), so a
        # point chosen by several methods runs once.
        trials: dict[int, Any] = {}
        try:
            for name in names:
                # Only maps (models, oracle) take the pick radius: random's and nearest's
                # scores are not maps.
                accept, std, radius, is_map = None, None, config.pick_radius, False
                if name == "oracle":
                    scores = episode.floor_label.astype(np.float64)
                elif name == "random":
                    scores = np.random.default_rng([config.seed, sid, ci, 1]).random(len(dist))
                    radius = 0.0
                    if (dist <= reach).any():
                        scores = np.where(dist <= reach, scores, -1.0)
                elif name == "nearest":
                    scores, radius = -dist, 0.0
                    accept = _base_free(runner, world_xy)
                elif isinstance(models[name], _ClassicalMethod):
                    try:
                        scores, is_map = models[name].episode_scores(episode, cfg), True
                    except MomaError as exc:
                        if exc.fatal:
                            raise
                        # A view the method cannot read (no floor plane to fit, say) is
                        # its failure on this configuration, not the run's end.
                        record["methods"][name] = {
                            "points": [],
                            "outcomes": [],
                            "stages": [],
                            "cause": exc.cause,
                        }
                        continue
                else:
                    arrays = {f: getattr(episode, f) for f in CLOUD_FIELDS}
                    scores, std = models[name](
                        episode_sample(arrays, sid, ci, ep, cfg.robot, opens)
                    )
                    is_map = True
                chosen = select_points(
                    floor_xy, scores, config.top_k, config.min_spread, accept, radius
                )
                for i in chosen:
                    if i not in trials:
                        trials[i] = runner.run(*world_xy[i])
                record["methods"][name] = {
                    "points": [[round(float(v), 4) for v in world_xy[i]] for i in chosen],
                    "outcomes": [int(trials[i].success) for i in chosen],
                    "stages": [int(trials[i].stage) for i in chosen],
                }
                if is_map:  # what the method said at its chosen points
                    record["methods"][name]["affordance"] = [
                        round(float(scores[i]), 4) for i in chosen
                    ]
                if std is not None:
                    record["methods"][name]["uncertainty"] = [
                        round(float(std[i]), 5) for i in chosen
                    ]
            if after is not None:
                context = {
                    "record": record,
                    "labels": labels,
                    "episode": episode,
                    "world_xy": world_xy,
                    "configuration": cfg,
                }
                after(runner, context)
        finally:
            runner.close()
    return record


def _base_free(runner: Any, world_xy: np.ndarray) -> Callable[[int], bool]:
    return lambda i: runner.base_free(*world_xy[i])


def run_msr(
    data: str | Path,
    checkpoints: Sequence[str | Path | tuple[str | Path, str]] = (),
    methods: Sequence[str] = (),
    config: MsrConfig | None = None,
    progress: bool = False,
    predictions: Sequence[tuple[str | Path, str | None]] = (),
) -> dict[str, Any]:
    """MSR of trained runs, predictions files and baselines on the configurations of a
    dataset split (none given: the bundled model).

    ``checkpoints``: run directories, reported by their model's name (``MODEL:DIR`` for a
    second run of one model), or ``(run directory, name)`` pairs reported as ``name``.

    ``predictions``: ``(file, name)`` pairs (name None: the file's stem); each file must
    hold a valid map of every episode of the configurations run (checked before the first
    one: MomaError naming the first bad episode).

    Returns ``{"config", "configurations", "methods": {name: {"top1", "topk", "trials",
    "per_robot", "per_category"}}, "records": [...]}`` (``topk``: Top-``top_k`` MSR; trained
    runs' entries also give ``floor_context``, the floor points encoded per view). A
    record holds, per configuration and method, the chosen world points, their outcomes
    (1 success, 0 failure) and stages. The same dataset, methods and config give the same
    result.
    """
    from tqdm.auto import tqdm

    from momakitchen.data.config import Preprocessing
    from momakitchen.data.integrity import check_shard_files
    from momakitchen.train.checkpoint import check_preprocessing

    config = config or MsrConfig()
    unknown = [m for m in methods if m not in METHODS]
    if unknown:
        raise MomaError(
            f"unknown MSR method {unknown[0]!r}; methods: {', '.join(METHODS)} "
            "(or --checkpoint RUN, --predictions FILE)"
        )
    if not checkpoints and not methods and not predictions:  # the bundled model
        from momakitchen.train.checkpoint import default_checkpoint

        checkpoints = [default_checkpoint()]
    root = Path(data)
    manifest, gen = dataset_generation(root)
    # Models score the episodes' stored clouds: they must be built as for their training.
    preprocessing = Preprocessing(gen.cloud, gen.camera.max_depth)

    models: dict[str, _Checkpoint | _PredictionsMethod | _ClassicalMethod] = {}
    for entry in checkpoints:
        run_dir, label = entry if isinstance(entry, tuple) else (entry, None)
        run = _Checkpoint(run_dir)
        check_preprocessing(run.run, preprocessing, f"dataset {str(root)!r}")
        name = label or (run.name if run.name not in models else f"{run.name}:{Path(run_dir).name}")
        if name in models or name in (*BASELINES, *methods):
            raise MomaError(
                f"checkpoint {str(run_dir)!r} would be reported as {name!r}, a name already "
                "taken by another method; give it another (--checkpoint NAME=RUN)"
            )
        models[name] = run

    todo = judged_configurations(root, manifest, config.split, config.max_configs)
    if predictions:
        from momakitchen.eval.predictions import load_predictions, split_episodes

        needed = split_episodes(manifest, config.split, [(sid, ci) for sid, ci, _ in todo])
        for path, label in predictions:
            method = _PredictionsMethod(load_predictions(path, needed, label))
            if method.name in models or method.name in (*BASELINES, *methods):
                raise MomaError(
                    f"predictions file {str(path)!r} would be reported as {method.name!r}, "
                    "a name already taken by another method; give it another name"
                )
            models[method.name] = method
    # Classical methods score maps as models do (the pick radius applies).
    for name in methods:
        if name in CLASSICAL:
            models[name] = _ClassicalMethod(name)
    methods = [m for m in methods if m not in CLASSICAL]
    names = [*models, *methods]
    # Every shard to be read is there and sound before the first (slow) configuration.
    check_shard_files(root, manifest, {sid for sid, _, _ in todo})

    records = []
    bar = tqdm(todo, desc="msr", unit="config", disable=not progress)
    for scene, shard, ci in rebuilt_configurations(root, bar, gen.scene):
        record = run_configuration(shard, scene, ci, gen, models, names, config)
        if record is not None:
            records.append(record)

    summaries = {name: _summary(records, name) for name in names}
    for name, model in models.items():  # the floor points each model encodes per view
        summaries[name]["floor_context"] = model.floor_context
    return {
        "dataset": str(root),
        "config": {
            "top_k": config.top_k,
            "min_spread": config.min_spread,
            "pick_radius": config.pick_radius,
            "seed": config.seed,
            "split": config.split,
            "max_configs": config.max_configs,
        },
        "configurations": len(records),
        "feasible_configurations": sum(r["feasible"] for r in records),
        "methods": summaries,
        "records": records,
    }


def _summary(records: list[dict[str, Any]], name: str) -> dict[str, Any]:
    """Rates of one method: overall, on feasible configurations (where some labelling trial
    succeeded), per robot and per target category."""

    def rates(recs: list[dict[str, Any]]) -> dict[str, Any]:
        outcomes = [r["methods"][name]["outcomes"] for r in recs]
        return {
            "top1": _rate([float(o[0]) if o else 0.0 for o in outcomes]),
            "topk": _rate([_rate(o) for o in outcomes]),
            "configurations": len(recs),
        }

    groups: dict[str, dict[str, list[dict[str, Any]]]] = {
        "per_robot": defaultdict(list),
        "per_category": defaultdict(list),
    }
    for r in records:
        groups["per_robot"][r["robot"]].append(r)
        groups["per_category"][mf.target_category(r["target"])].append(r)
    overall = rates(records)
    feasible = rates([r for r in records if r["feasible"]])
    return {
        "top1": overall["top1"],
        "topk": overall["topk"],
        "top1_feasible": feasible["top1"],
        "topk_feasible": feasible["topk"],
        "trials": sum(len(r["methods"][name]["outcomes"]) for r in records),
        **{g: {k: rates(v) for k, v in sorted(d.items())} for g, d in groups.items()},
    }


# What identifies a configuration's record apart from the methods' picks.
_RECORD_KEYS = ("scene_id", "config_index", "episode_index", "robot", "target", "feasible")


def _record_keys(label: str, result: dict[str, Any]) -> list[tuple]:
    try:
        return [tuple(r[k] for k in _RECORD_KEYS) for r in result["records"]]
    except (KeyError, TypeError) as exc:
        raise MomaError(f"{label!r} has a malformed record: {exc!r}") from exc


def _settings(result: dict[str, Any]) -> dict[str, Any]:
    """An MSR result's settings; files written before ``pick_radius`` existed ranked by the
    raw map, i.e. radius 0."""
    return {"pick_radius": 0.0, **result["config"]}


def check_same_views(a: tuple[str, dict[str, Any]], b: tuple[str, dict[str, Any]]) -> None:
    """MomaError unless two ``(label, MSR result)`` pairs share dataset, settings and the
    configurations and views they tried, so that their outcomes pair up record by record."""
    (label0, first), (label, part) = a, b
    if (settings := _settings(part)) != (settings0 := _settings(first)):
        raise MomaError(
            f"MSR settings of {label!r} ({settings}) differ from {label0!r} ({settings0})"
        )
    if Path(str(part.get("dataset"))).resolve() != Path(str(first.get("dataset"))).resolve():
        raise MomaError(
            f"{label!r} is on dataset {part.get('dataset')!r}, {label0!r} on "
            f"{first.get('dataset')!r}"
        )
    if _record_keys(label, part) != _record_keys(label0, first):
        raise MomaError(
            f"{label!r} and {label0!r} cover different configurations or views "
            "(other configurations, or the same in another order)"
        )


def merge_msr(parts: Sequence[tuple[str, dict[str, Any]]]) -> dict[str, Any]:
    """One MSR result from several runs over the same configurations, each with its own
    methods (e.g. one ``momakitchen msr`` per trained model, kept beside its run, and one
    for the baselines). Valid because a configuration's view and random picks depend only
    on ``(seed, scene, configuration)``, not on which methods ran together.

    Args:
        parts: ``(label, result)`` pairs; the label names a part in errors (its file).

    Returns:
        the result as if every method had run at once (methods in the order given).

    Raises:
        MomaError: the parts differ in dataset, settings or configurations, or share a
            method, or one is not an MSR result.
    """
    if not parts:
        raise MomaError("no MSR results to merge")
    (label0, first), *rest = parts
    for label, part in parts:
        if (
            not isinstance(part, dict)
            or not {"config", "methods", "records"} <= set(part)
            or not isinstance(part["config"], dict)
        ):
            raise MomaError(f"{label!r} is not a `momakitchen msr` result")
    merged = {k: v for k, v in first.items() if k != "seconds"}
    merged["config"] = _settings(first)
    merged["methods"] = dict(first["methods"])
    merged["records"] = [{**r, "methods": dict(r["methods"])} for r in first["records"]]
    for label, part in rest:
        check_same_views((label0, first), (label, part))
        shared = sorted(set(part["methods"]) & set(merged["methods"]))
        if shared:
            raise MomaError(f"{label!r} repeats methods {shared} of an earlier MSR result")
        merged["methods"].update(part["methods"])
        for into, rec in zip(merged["records"], part["records"], strict=True):
            into["methods"].update(rec["methods"])
    return merged


def format_msr_table(result: dict[str, Any]) -> str:
    """A plain-text table: method, Top-1 and Top-k MSR (all and feasible configurations;
    the Top-k columns only when k > 1), trials run."""
    k = result["config"]["top_k"]
    keys = RATE_KEYS if k > 1 else ("top1", "top1_feasible")
    heads = {
        "top1": "Top-1 MSR",
        "topk": f"Top-{k} MSR",
        "top1_feasible": "Top-1 (feasible)",
        "topk_feasible": f"Top-{k} (feasible)",
    }
    rows = [("method", *(heads[key] for key in keys), "trials")]
    for name, m in result["methods"].items():
        rows.append((name, *(f"{100 * m[key]:.1f} %" for key in keys), str(m["trials"])))
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    lines = [
        "  ".join(
            c.ljust(w) if i == 0 else c.rjust(w)
            for i, (c, w) in enumerate(zip(r, widths, strict=True))
        )
        for r in rows
    ]
    lines.insert(1, "-" * len(lines[0]))
    lines.append(
        f"({result['configurations']} configurations of the "
        f"{result['config']['split']} split, {result['feasible_configurations']} "
        "feasible: some labelling trial succeeded; trials: the points each method tried in "
        f"physics, up to {k} per configuration)"
    )
    return "\n".join(lines)
