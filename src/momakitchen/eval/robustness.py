"""The robustness track: a model on the frames a real robot would give it.

For each configuration of a split, the view that ``msr`` picks for the same seed is
taken as a perfect render and corrupted by each named corruption
(:data:`momakitchen.perception.sensors.CORRUPTIONS`: sensor noise, segmenter masks,
calibration errors, monocular depth); the corrupted frame goes through the real-robot
path (:func:`momakitchen.perception.live.frame_inputs`, floor-plane correction
included) and the model's Top-k base positions, in the frame the robot believes, are
driven to and tried with the labelling's own trial in PyBullet. Map metrics compare the
predicted map with the ground truth at the same floor points (the labels' interpolation
at those points, :func:`momakitchen.sim.labels.floor_affordance`).

Views whose target lies beyond the sensor's working range are counted apart (a robot
there should move closer, not trust a model); every other failure to predict is an error
counted by its cause.
"""

from __future__ import annotations

import zlib
from collections import Counter
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np

from momakitchen.errors import MomaError

SPLITS = ("test", "train", "all")
# Error causes, from the messages of frame_inputs / fit_floor (one word each for tables).
ERROR_CAUSES = {
    "the target mask is empty": "empty_mask",
    "but none with a valid depth": "no_target_depth",
    "beyond the": "target_range",
    "no floor plane found": "no_floor",
    "no floor is visible": "no_floor",
}


# Causes that leave no target to act on: the corrupted mask has no pixel of valid depth.
NO_TARGET = ("empty_mask", "no_target_depth")


def error_cause(message: str) -> str:
    """The cause of a prediction error, from its message (``other`` if unknown)."""
    for needle, cause in ERROR_CAUSES.items():
        if needle in message:
            return cause
    return "other"


@dataclass(frozen=True)
class RobustnessConfig:
    """Settings of a robustness run (those of ``msr`` where they mean the same).

    Attributes:
        corruptions: names from ``CORRUPTIONS`` (``clean`` first is the reference).
        top_k, min_spread, pick_radius: as ``MsrConfig``.
        seed: picks the same view per configuration as ``msr --seed``; also seeds the
            corruptions (with the episode and the corruption's name).
        split, max_configs: which configurations.
    """

    corruptions: tuple[str, ...] = ("clean",)
    top_k: int = 1
    min_spread: float = 0.2
    pick_radius: float = 0.0
    seed: int = 0
    split: str = "test"
    max_configs: int = 0

    def __post_init__(self) -> None:
        from momakitchen.perception.sensors import get_corruption

        if not self.corruptions:
            raise MomaError("RobustnessConfig.corruptions is empty")
        for name in self.corruptions:
            get_corruption(name)
        if len(set(self.corruptions)) != len(self.corruptions):
            raise MomaError(f"corruptions named twice: {list(self.corruptions)}")
        if not 1 <= self.top_k <= 20:
            raise MomaError(f"RobustnessConfig.top_k must be in [1, 20], got {self.top_k}")
        if not 0.0 <= self.min_spread <= 2.0 or not 0.0 <= self.pick_radius <= 1.0:
            raise MomaError("min_spread must be in [0, 2] m and pick_radius in [0, 1] m")
        if self.seed < 0 or self.max_configs < 0:
            raise MomaError("seed and max_configs must be >= 0")
        if self.split not in SPLITS:
            raise MomaError(f"split must be one of {SPLITS}, got {self.split!r}")


def episode_frame(episode: Any) -> Any:
    """A stored :class:`~momakitchen.data.episode.Episode`'s render as a
    :class:`~momakitchen.perception.sensors.Frame`."""
    from momakitchen.data.episode import stored_frame

    names = ("depth", "rgb", "semantic", "intrinsics", "camera_to_base")
    return stored_frame({n: getattr(episode, n) for n in names})


def corruption_rng(seed: int, ids: Sequence[int], name: str) -> np.random.Generator:
    """The generator of one corruption of one episode: the same every run."""
    return np.random.default_rng([seed, *(int(i) for i in ids), zlib.crc32(name.encode())])


def target_range(frame: Any) -> float:
    """The target's distance from the camera along the optical axis (m): the median
    depth of its pixels in the clean render (inf without any)."""
    d = frame.depth[frame.target_mask]
    d = d[np.isfinite(d) & (d > 0)]
    return float(np.median(d)) if len(d) else float("inf")


def view_inputs(
    frame: Any, corruption_name: str, ids: tuple[int, int, int], preprocessing: Any, seed: int
) -> Any:
    """The real-robot input of one view under one corruption, the same for every model
    built with ``preprocessing``: a
    :class:`~momakitchen.perception.live.FrameClouds`, or the view's status
    (``{"status": "beyond_range" | "error", ...}``) when there is none."""
    return corrupted_view(frame, corruption_name, ids, preprocessing, seed)[1]


def corrupted_view(
    frame: Any, corruption_name: str, ids: tuple[int, int, int], preprocessing: Any, seed: int
) -> tuple[Any, Any]:
    """The corrupted frame (None for a target beyond the sensor's range, which is not
    corrupted) and :func:`view_inputs`' result."""
    from momakitchen.perception.live import frame_inputs
    from momakitchen.perception.sensors import corrupt_frame, get_corruption

    corruption = get_corruption(corruption_name)
    distance = target_range(frame)
    if distance > corruption.preset.max_range:
        return None, {"status": "beyond_range", "target_range": round(distance, 3)}
    bad = corrupt_frame(frame, corruption, corruption_rng(seed, ids, corruption_name))
    try:
        return bad, frame_inputs(
            bad.depth,
            np.isfinite(bad.depth) & (bad.depth > 0),
            bad.rgb,
            bad.target_mask,
            list(bad.obstacle_masks),
            bad.intrinsics,
            bad.camera_to_base,
            preprocessing.cloud,
            preprocessing.max_depth,
            metric_depth=corruption.preset.depth.metric,
        )
    except MomaError as exc:
        return bad, _error(exc)


def _error(exc: MomaError) -> dict[str, Any]:
    return {"status": "error", "cause": error_cause(str(exc)), "message": str(exc)}


def view_key(corruption: str, scene_id: int, config_index: int, episode_index: int) -> str:
    """A view's key in robustness inputs and predictions files:
    ``"corruption/scene/config/episode"``."""
    from momakitchen.eval.predictions import episode_key

    return f"{corruption}/{episode_key(scene_id, config_index, episode_index)}"


@dataclass(frozen=True)
class PredictionsMethod:
    """A method that ran elsewhere, as a robustness-track method: its map of each view's
    floor points (a predictions file keyed by :func:`view_key`, written from
    :func:`export_robustness_inputs`)."""

    name: str
    path: Path
    maps: dict[str, np.ndarray]

    def predict(self, key: str, inputs: Any, robot: str, config: RobustnessConfig) -> Any:
        """The view's :class:`~momakitchen.models.inference.Prediction`: the stored map
        and the poses ``predict`` would choose from it (no uncertainty)."""
        from momakitchen.models.inference import map_prediction

        where = f"predictions file {str(self.path)!r}"
        if key not in self.maps:
            raise MomaError(
                f"{where} lacks view {key!r}: score every view of export-inputs "
                "--robustness made with the same --split, --seed and corruptions"
            )
        scores = self.maps[key].astype(np.float64)
        n = len(inputs.floor_xyz)
        if len(scores) != n:
            raise MomaError(
                f"{where}: view {key!r} has {len(scores)} values, the view {n} floor points "
                "(inputs exported with another --seed or momakitchen version?)"
            )
        return map_prediction(
            inputs.floor_xyz,
            scores,
            np.zeros(n),
            inputs.target_xyz,
            robot,
            self.name,
            top_k=config.top_k,
            min_spread=config.min_spread,
            pick_radius=config.pick_radius,
            correction=inputs.correction,
        )


def load_robustness_predictions(
    path: str | Path, corruptions: Sequence[str], name: str | None = None
) -> PredictionsMethod:
    """Read a robustness predictions file and check, before any work, that it has maps
    for every corruption and that each map of theirs is a 1-D array of numbers in
    [0, 1] (its length is checked against each view's floor points as it is judged)."""
    from momakitchen.eval.predictions import check_predictions, method_name, read_predictions

    maps = read_predictions(path)
    kept = {}
    for corruption in corruptions:
        keys = [k for k in maps if k.startswith(f"{corruption}/") and k.count("/") == 3]
        if not keys:
            raise MomaError(
                f"predictions file {str(path)!r} has no maps for corruption {corruption!r} "
                "(keys 'corruption/scene/config/episode', from export-inputs --robustness)"
            )
        for k in keys:
            if maps[k].ndim != 1:
                raise MomaError(
                    f"predictions file {str(path)!r}: view {k!r} has shape "
                    f"{maps[k].shape}, not one value per floor point"
                )
            kept[k] = maps[k]
    check_predictions(kept, [(k, len(v)) for k, v in kept.items()], path)
    return PredictionsMethod(method_name(path, name), Path(path), kept)


def predict_view(
    run: Any,
    inputs: Any,
    robot: str,
    descriptor: np.ndarray,
    config: RobustnessConfig,
    key: str = "",
) -> dict[str, Any]:
    """One model (a loaded run, or a :class:`PredictionsMethod` with the view's ``key``)
    on one view's input (:func:`view_inputs`): ``{"status": "ok", "prediction":
    Prediction}``, or a copy of the view's status when it has no input."""
    from momakitchen.models.inference import predict_map

    if isinstance(inputs, dict):
        return dict(inputs)
    if isinstance(run, PredictionsMethod):  # a bad file is the user's error, not the view's
        return {"status": "ok", "prediction": run.predict(key, inputs, robot, config)}
    try:
        pred = predict_map(
            run,
            inputs,
            robot,
            descriptor,
            top_k=config.top_k,
            min_spread=config.min_spread,
            pick_radius=config.pick_radius,
            mc_samples=0,
        )
    except MomaError as exc:
        return _error(exc)
    return {"status": "ok", "prediction": pred}


def run_view(
    run: Any,
    frame: Any,
    corruption_name: str,
    ids: tuple[int, int, int],
    robot: str,
    descriptor: np.ndarray,
    config: RobustnessConfig,
) -> dict[str, Any]:
    """One model on one corrupted view: ``{"status": "ok"|"beyond_range"|"error", ...}``
    with the prediction (``prediction``) when ok."""
    preprocessing = None if run is None else run.preprocessing
    inputs = view_inputs(frame, corruption_name, ids, preprocessing, config.seed)
    return predict_view(run, inputs, robot, descriptor, config)


def run_robustness(
    data: str | Path,
    checkpoints: Sequence[str | Path] = (),
    config: RobustnessConfig | None = None,
    progress: bool = False,
    view_maps: dict[str, Any] | None = None,
    predictions: Sequence[tuple[str | Path, str | None]] = (),
) -> dict[str, Any]:
    """The robustness track of trained runs and of methods that ran elsewhere
    (``predictions``: ``(file, name or None)`` pairs, :func:`load_robustness_predictions`)
    on a dataset split; with neither, the bundled model. ``view_maps``, if given, receives
    the first model's prediction of the first configuration's view under each corruption
    (name -> Prediction or the error), for :func:`robustness_figure`.

    Returns ``{"config", "configurations", "models": {model: {corruption: summary}},
    "records": [...]}``; a summary has ``views``, ``beyond_range``, ``errors`` (by cause),
    ``top1`` (views beyond range left out; errors count as failures), ``top1_usable``
    (also leaving out the views whose mask kept no target pixel of valid depth),
    ``top1_feasible``,
    ``topk``, ``pcc``, ``sim`` (over the views predicted)."""
    from tqdm.auto import tqdm

    from momakitchen.data.config import Preprocessing
    from momakitchen.data.integrity import check_shard_files
    from momakitchen.eval.msr import dataset_generation, judged_configurations, view_record
    from momakitchen.frames import base_to_world_xy
    from momakitchen.metrics import episode_metrics
    from momakitchen.robots.spec import get_robot_spec, robot_descriptor
    from momakitchen.sim.labels import floor_affordance
    from momakitchen.sim.trials import TrialRunner
    from momakitchen.sim.world import World
    from momakitchen.train.checkpoint import (
        check_preprocessing,
        default_checkpoint,
        load_checkpoint,
    )

    config = config or RobustnessConfig()
    root = Path(data)
    manifest, gen = dataset_generation(root)
    preprocessing = Preprocessing(gen.cloud, gen.camera.max_depth)
    runs: dict[str, Any] = {}
    for run_dir in checkpoints or ([] if predictions else [default_checkpoint()]):
        run = load_checkpoint(run_dir)
        check_preprocessing(run, preprocessing, f"dataset {str(root)!r}")
        name = (
            run.config.model
            if run.config.model not in runs
            else f"{run.config.model}:{Path(run_dir).name}"
        )
        runs[name] = run
    for path, label in predictions:
        method = load_robustness_predictions(path, config.corruptions, label)
        if method.name in runs:
            raise MomaError(f"two methods are named {method.name!r}: give --name")
        runs[method.name] = method
    todo = judged_configurations(root, manifest, config.split, config.max_configs)
    check_shard_files(root, manifest, {sid for sid, _, _ in todo})

    records: list[dict[str, Any]] = []
    bar = tqdm(todo, desc="robustness", unit="config", disable=not progress)
    for scene, shard, ci, ep in judged_views(root, bar, gen, config.seed):
        sid = scene.layout.scene_id
        labels = shard.configuration(ci)
        cfg = scene.configurations[ci]
        episode = shard.episode(ci, ep)
        frame = episode_frame(episode)
        descriptor = np.asarray(robot_descriptor(get_robot_spec(cfg.robot)), np.float32)
        grid: Any = SimpleNamespace(
            positions=labels.trial_positions, outcomes=labels.trial_outcomes
        )
        record = view_record(
            sid, ci, ep, labels, target_range=round(target_range(frame), 3), views={}
        )
        with World(scene.layout) as world:
            world.load_configuration(cfg)
            runner = TrialRunner(world, cfg.robot, gen.trial)
            trials: dict[tuple[float, float], Any] = {}
            try:
                for name in config.corruptions:
                    # one corrupted frame and one input per corruption, for every model
                    inputs = view_inputs(frame, name, (sid, ci, ep), preprocessing, config.seed)
                    gt = None
                    if not isinstance(inputs, dict):  # the truth at the input's floor points
                        gt = floor_affordance(
                            grid,
                            scene.layout,
                            cfg,
                            inputs.floor_xyz[:, :2],
                            episode.base_pose,
                            gen.dense,
                        ).astype(np.float64)
                    key = view_key(name, sid, ci, ep)
                    for model, run in runs.items():
                        view = predict_view(run, inputs, cfg.robot, descriptor, config, key)
                        pred = view.pop("prediction", None)
                        if view_maps is not None and not records and model == next(iter(runs)):
                            view_maps[name] = pred if pred is not None else view
                        if pred is not None:
                            world_xy = base_to_world_xy(pred.poses[:, :2], episode.base_pose)
                            outcomes, stages = [], []
                            for x, y in world_xy:
                                at = (round(float(x), 4), round(float(y), 4))
                                if at not in trials:
                                    trials[at] = runner.run(*at)
                                outcomes.append(int(trials[at].success))
                                stages.append(int(trials[at].stage))
                            assert gt is not None  # a prediction means an input
                            m = episode_metrics(pred.affordance, gt)
                            view.update(
                                points=[[round(float(v), 4) for v in p] for p in world_xy],
                                outcomes=outcomes,
                                stages=stages,
                                pcc=round(m["pcc"], 5),
                                sim=round(m["sim"], 5),
                                correction=(pred.correction.to_dict() if pred.correction else None),
                            )
                        record["views"].setdefault(model, {})[name] = view
            finally:
                runner.close()
        records.append(record)

    models = {
        model: {name: summarize(records, model, name) for name in config.corruptions}
        for model in runs
    }
    return {
        "dataset": str(root),
        "config": {**asdict(config), "corruptions": list(config.corruptions)},
        "configurations": len(records),
        "models": models,
        "records": records,
    }


def judged_views(
    root: Path, todo: Iterable[tuple[int, int, str]], gen: Any, seed: int
) -> Iterator[tuple[Any, Any, int, int]]:
    """(scene, shard, config_index, episode_index) of the view ``msr`` judges for ``seed``
    in each configuration of ``todo`` that has one."""
    from momakitchen.eval.msr import msr_view, rebuilt_configurations

    for scene, shard, ci in rebuilt_configurations(root, todo, gen.scene):
        ep = msr_view(shard, scene, ci, seed)
        if ep is not None:
            yield scene, shard, ci, ep


ROBUSTNESS_INPUTS_FORMAT = "momakitchen-robustness-inputs-1"


def export_robustness_inputs(
    data: str | Path,
    out: str | Path,
    config: RobustnessConfig,
    images: bool = False,
    progress: bool = False,
) -> dict[str, int]:
    """Write the robustness track's inputs, for a method that runs elsewhere: the view
    ``msr`` judges for ``config.seed`` in each configuration, under each corruption,
    through the real-robot path exactly as :func:`run_robustness` gives it to a model.

    Under the key ``K`` = ``"corruption/scene/config/episode"`` (:func:`view_key`) of an
    ``.npz`` or ``.h5`` file: ``K/status`` (``ok``, ``beyond_range`` or ``error``, with
    ``K/reason``) for every view, and for the ``ok`` ones the fields of
    :data:`~momakitchen.eval.predictions.INPUT_FIELDS` (the corrupted cloud, the floor
    points to score in this order), ``K/target_xyz`` (3,), ``K/floor_correction`` (4, 4)
    (already applied to the points), ``K/robot_name``; ``intrinsics`` and
    ``camera_to_base`` are the calibration the robot believes. ``images``: also the
    corrupted ``K/rgb``, ``K/depth`` (0: no return) and ``K/target_mask`` (uint8).
    Returns the number of views by status.
    """
    from tqdm.auto import tqdm

    from momakitchen.data.config import Preprocessing
    from momakitchen.data.integrity import check_shard_files
    from momakitchen.eval.msr import dataset_generation, judged_configurations
    from momakitchen.eval.predictions import INPUT_FIELDS, file_kind, write_arrays
    from momakitchen.robots.spec import DESCRIPTOR_NAMES, get_robot_spec, robot_descriptor

    root, out = Path(data), Path(out)
    file_kind(out)
    manifest, gen = dataset_generation(root)
    preprocessing = Preprocessing(gen.cloud, gen.camera.max_depth)
    todo = judged_configurations(root, manifest, config.split, config.max_configs)
    check_shard_files(root, manifest, {sid for sid, _, _ in todo})
    counts: Counter[str] = Counter()

    def arrays() -> Iterator[tuple[str, np.ndarray]]:
        bar = tqdm(todo, desc="export", unit="config", disable=not progress)
        for scene, shard, ci, ep in judged_views(root, bar, gen, config.seed):
            sid = scene.layout.scene_id
            robot = scene.configurations[ci].robot
            frame = episode_frame(shard.episode(ci, ep))
            descriptor = np.asarray(robot_descriptor(get_robot_spec(robot)), np.float32)
            for name in config.corruptions:
                key = view_key(name, sid, ci, ep)
                bad, inputs = corrupted_view(frame, name, (sid, ci, ep), preprocessing, config.seed)
                if isinstance(inputs, dict):
                    counts[inputs["status"]] += 1
                    yield f"{key}/status", np.asarray(inputs["status"])
                    reason = inputs.get("message") or (
                        f"the target is {inputs['target_range']:.2f} m away, beyond the "
                        "sensor's range"
                    )
                    yield f"{key}/reason", np.asarray(reason)
                    continue
                counts["ok"] += 1
                k = bad.intrinsics
                clouds = inputs.arrays()
                fields = {
                    out_name: np.asarray(clouds[field], dtype)
                    for out_name, field, dtype, _ in INPUT_FIELDS
                    if field in clouds
                } | {
                    "target_xyz": np.asarray(inputs.target_xyz, np.float64),
                    "robot": descriptor,
                    "intrinsics": np.asarray([k.fx, k.fy, k.cx, k.cy], np.float64),
                    "camera_to_base": np.asarray(bad.camera_to_base, np.float64),
                    "floor_correction": inputs.correction.matrix,
                }
                if images:
                    depth = np.nan_to_num(np.asarray(bad.depth, np.float32), nan=0.0)
                    fields |= {
                        "rgb": np.asarray(bad.rgb, np.uint8),
                        "depth": depth,
                        "target_mask": np.asarray(bad.target_mask, np.uint8),
                    }
                yield f"{key}/status", np.asarray("ok")
                for field, value in fields.items():
                    yield f"{key}/{field}", np.asarray(value)
                yield f"{key}/robot_name", np.asarray(robot)

    attrs = {
        "format": np.asarray(ROBUSTNESS_INPUTS_FORMAT),
        "split": np.asarray(config.split),
        "seed": np.asarray(config.seed),
        "corruptions": np.asarray(list(config.corruptions)),
        "descriptor_names": np.asarray(DESCRIPTOR_NAMES),
    }
    out.parent.mkdir(parents=True, exist_ok=True)
    write_arrays(out, arrays(), attrs)
    return dict(counts)


def summarize(records: Sequence[dict[str, Any]], model: str, name: str) -> dict[str, Any]:
    """One model's figures under one corruption (see :func:`run_robustness`)."""
    views = [(r, r["views"][model][name]) for r in records if name in r["views"].get(model, {})]
    counted = [(r, v) for r, v in views if v["status"] != "beyond_range"]
    ok = [v for _, v in counted if v["status"] == "ok"]

    def rate(items: list[tuple[dict[str, Any], dict[str, Any]]], k: bool) -> float:
        vals = [
            (float(np.mean(v["outcomes"])) if k else float(v["outcomes"][0]))
            if v["status"] == "ok"
            else 0.0
            for _, v in items
        ]
        return round(float(np.mean(vals)), 4) if vals else 0.0

    feasible = [(r, v) for r, v in counted if r["feasible"]]
    # views left with a target pixel of valid depth: what any method could act on
    usable = [(r, v) for r, v in counted if v.get("cause") not in NO_TARGET]
    return {
        "views": len(views),
        "beyond_range": sum(v["status"] == "beyond_range" for _, v in views),
        "errors": dict(Counter(v["cause"] for _, v in counted if v["status"] == "error")),
        "top1": rate(counted, False),
        "top1_usable": rate(usable, False),
        "top1_feasible": rate(feasible, False),
        "topk": rate(counted, True),
        "pcc": round(float(np.mean([v["pcc"] for v in ok])), 4) if ok else 0.0,
        "sim": round(float(np.mean([v["sim"] for v in ok])), 4) if ok else 0.0,
    }


def _vs_clean(s: dict[str, Any], ref: dict[str, Any] | None, name: str) -> tuple[str, str]:
    """A row's Top-1 (points) and PCC changes from ``clean`` ("" for clean itself)."""
    if ref is None or name == "clean":
        return "", ""
    return f"{(s['top1'] - ref['top1']) * 100:+.1f}", f"{s['pcc'] - ref['pcc']:+.3f}"


def format_robustness_table(result: dict[str, Any]) -> str:
    """A text table: one row per model and corruption, with the change from ``clean``
    (``usable``: Top-1 over the views whose mask kept a target pixel of valid depth)."""
    k = result["config"]["top_k"]
    head = (
        f"{'model':<12} {'corruption':<14} {'views':>5} {'range':>5} {'errors':>6} "
        f"{'Top-1':>6} {'dTop-1':>7} {'usable':>6} {'feas.':>6}"
        + (f" {f'Top-{k}':>6}" if k > 1 else "")
        + f" {'PCC':>6} {'dPCC':>6} {'SIM':>6}"
    )
    lines = [head, "-" * len(head)]
    for model, rows in result["models"].items():
        ref = rows.get("clean")
        for name, s in rows.items():
            d1, dp = _vs_clean(s, ref, name)
            lines.append(
                f"{model:<12} {name:<14} {s['views']:>5} {s['beyond_range']:>5} "
                f"{sum(s['errors'].values()):>6} {s['top1'] * 100:>6.1f} {d1:>7} "
                f"{s.get('top1_usable', s['top1']) * 100:>6.1f} {s['top1_feasible'] * 100:>6.1f}"
                + (f" {s['topk'] * 100:>6.1f}" if k > 1 else "")
                + f" {s['pcc']:>6.3f} {dp:>6} {s['sim']:>6.3f}"
            )
    return "\n".join(lines)


def robustness_figure(view_maps: dict[str, Any], title: str) -> bytes:
    """One view's map under each corruption, on one 0-1 colour scale (PNG bytes)."""
    from momakitchen.perception.figures import floor_map, png_bytes, pyplot

    plt = pyplot()
    names = list(view_maps)
    cols = min(5, len(names))
    rows = (len(names) + cols - 1) // cols
    fig, axes = plt.subplots(
        rows,
        cols,
        figsize=(2.9 * cols + 1.0, 2.7 * rows + 0.5),
        squeeze=False,
        constrained_layout=True,
    )
    preds = [p for p in view_maps.values() if hasattr(p, "floor_xyz")]
    # the floor within 1.2 m of the target, where the robot may stand
    t = preds[0].target_xyz[:2] if preds else np.zeros(2)
    extent = (float(t[0] - 1.2), float(t[0] + 0.3), float(t[1] - 1.2), float(t[1] + 1.2))
    scatter = None
    for ax, name in zip(axes.flat, names, strict=False):
        p = view_maps[name]
        if hasattr(p, "floor_xyz"):
            scatter = floor_map(
                ax, p.floor_xyz, p.affordance, name, p.target_xyz, p.poses[:1], extent=extent
            )
        else:
            ax.set_title(name, fontsize=9)
            reason = (
                "target beyond the sensor's range"
                if p["status"] == "beyond_range"
                else (p.get("cause", "error").replace("_", " "))
            )
            ax.text(0.5, 0.5, reason, ha="center", va="center", transform=ax.transAxes)
            ax.set_xticks([])
            ax.set_yticks([])
    for i, ax in enumerate(axes.flat):
        if i >= len(names):
            ax.axis("off")
            continue
        if i % cols:  # one axis label per row and column is enough
            ax.set_ylabel("")
        if i < len(names) - cols:
            ax.set_xlabel("")
    if scatter is not None:
        fig.colorbar(scatter, ax=axes, shrink=0.6, label="predicted affordance (0-1)")
    fig.suptitle(title, fontsize=10)
    return png_bytes(fig)


def top1_by_view(result: dict[str, Any], model: str, corruption: str) -> dict[tuple, int]:
    """Each counted view's Top-1 outcome (errors: 0; views beyond range left out), keyed
    by (seed, scene, configuration, episode): the record's own ``seed`` where results of
    several seeds are pooled, else the run's."""
    out = {}
    for r in result["records"]:
        v = r["views"].get(model, {}).get(corruption)
        if v is None or v["status"] == "beyond_range":
            continue
        seed = r.get("seed", result["config"]["seed"])
        key = (seed, r["scene_id"], r["config_index"], r["episode_index"])
        out[key] = int(v["outcomes"][0]) if v["status"] == "ok" else 0
    return out


def robustness_markdown(results: Sequence[dict[str, Any]]) -> list[str]:
    """Markdown lines: one table row per model and corruption (``robustness`` results,
    merged), with the change from ``clean``, and McNemar's test of every pair of models
    under each combined corruption (Top-1 per view, the views both counted)."""
    from momakitchen.eval.stats import mcnemar

    models: dict[str, tuple[dict[str, Any], dict[str, Any]]] = {}
    for res in results:
        for model in res["models"]:
            if model in models:
                raise MomaError(f"robustness results name model {model!r} twice")
            names = res["config"]["corruptions"]
            rows = {name: summarize(res["records"], model, name) for name in names}
            models[model] = (rows, res)
    lines = [
        "| model | corruption | views | beyond range | errors | Top-1 | vs clean "
        "| Top-1, usable masks | PCC | vs clean | SIM |",
        "| --- | --- | ---: | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for model, (rows, _) in models.items():
        ref = rows.get("clean")
        for name, s in rows.items():
            errors = ", ".join(f"{k} {v}" for k, v in s["errors"].items()) or "0"
            d1, dp = _vs_clean(s, ref, name)
            lines.append(
                f"| {model} | {name} | {s['views']} | {s['beyond_range']} | {errors} | "
                f"{s['top1'] * 100:.1f} | {d1} | {s['top1_usable'] * 100:.1f} | "
                f"{s['pcc']:.3f} | {dp} | {s['sim']:.3f} |"
            )
    names = list(models)
    pairs = [(a, b) for i, a in enumerate(names) for b in names[i + 1 :]]
    tests = []
    for a, b in pairs:
        (ra, res_a), (rb, res_b) = models[a], models[b]
        for corruption in [c for c in ra if c in rb and (c == "clean" or "combined" in c)]:
            oa = top1_by_view(res_a, a, corruption)
            ob = top1_by_view(res_b, b, corruption)
            common = sorted(set(oa) & set(ob))
            if not common:
                continue
            only_a, only_b, p = mcnemar([oa[k] for k in common], [ob[k] for k in common])
            tests.append(
                f"| {a} vs {b} | {corruption} | {len(common)} | {only_a} | {only_b} | {p:.3g} |"
            )
    if tests:
        lines += [
            "",
            "| McNemar (Top-1 per view) | corruption | views | only first | only second | p |",
            "| --- | --- | ---: | ---: | ---: | ---: |",
            *tests,
        ]
    return lines
