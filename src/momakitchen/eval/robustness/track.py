"""A robustness run over a dataset split (the track: :mod:`momakitchen.eval.robustness`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np

from momakitchen.data.episode import episode_frame
from momakitchen.errors import MomaError
from momakitchen.eval.methods import CLASSICAL
from momakitchen.eval.robustness.tables import summarize
from momakitchen.eval.robustness.views import (
    REFERENCE,
    ClassicalMethod,
    RobustnessConfig,
    StoredView,
    judged_views,
    load_robustness_predictions,
    predict_view,
    track_view,
    view_key,
)
from momakitchen.perception.sensors import get_corruption, target_range


def run_robustness(
    data: str | Path,
    checkpoints: Sequence[str | Path] = (),
    config: RobustnessConfig | None = None,
    progress: bool = False,
    view_maps: dict[str, Any] | None = None,
    predictions: Sequence[tuple[str | Path, str | None]] = (),
    methods: Sequence[str] = (),
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
    ``top1_feasible``, ``topk``, ``pcc``, ``sim`` (over the views predicted). The clean
    row's ``top1`` is ``msr``'s Top-1 MSR for the same views, seed, ``min_spread`` and
    ``pick_radius``."""
    from tqdm.auto import tqdm

    from momakitchen.data.config import Preprocessing
    from momakitchen.data.integrity import check_shard_files
    from momakitchen.data.reader import dataset_generation, judged_configurations, view_record
    from momakitchen.frames import base_to_world_xy
    from momakitchen.metrics import episode_metrics
    from momakitchen.robots.descriptor import robot_descriptor
    from momakitchen.robots.spec import get_robot_spec
    from momakitchen.sim.labels import floor_affordance
    from momakitchen.sim.trials import TrialRunner
    from momakitchen.sim.world import World
    from momakitchen.train.checkpoint import (
        check_preprocessing,
        default_checkpoint,
        load_checkpoint,
        run_label,
    )

    config = config or RobustnessConfig()
    root = Path(data)
    manifest, gen = dataset_generation(root)
    preprocessing = Preprocessing(gen.cloud, gen.camera.max_depth)
    runs: dict[str, Any] = {}
    for run_dir in checkpoints or ([] if predictions or methods else [default_checkpoint()]):
        run = load_checkpoint(run_dir)
        check_preprocessing(run, preprocessing, f"dataset {str(root)!r}")
        name = run_label(run)
        if name in runs:
            name = f"{name}:{Path(run_dir).name}"
        runs[name] = run
    for name in methods:  # classical base placement: ring, reachability
        if name not in CLASSICAL:
            raise MomaError(f"unknown method {name!r}; classical methods: {', '.join(CLASSICAL)}")
        if name in runs:
            raise MomaError(f"method named twice: {name!r}")
        runs[name] = ClassicalMethod(name)
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
        descriptor = np.asarray(
            robot_descriptor(get_robot_spec(cfg.robot), cfg.mount_height), np.float32
        )
        grid: Any = SimpleNamespace(
            positions=labels.trial_positions, outcomes=labels.trial_outcomes
        )
        record = view_record(
            sid, ci, ep, labels, target_range=round(target_range(frame), 3), views={}
        )
        with World(scene.layout) as world:
            world.load_configuration(cfg)
            runner = TrialRunner(world, cfg.robot, gen.trial)
            # Trials do not depend on earlier ones (the world is restored before each): a
            # point chosen under several corruptions or by several models runs once.
            trials: dict[tuple[float, float], Any] = {}
            try:
                for name in config.corruptions:
                    # one input per corruption, for every model
                    view_frame, inputs = track_view(
                        episode, frame, name, cfg.target.anchor, preprocessing, config.seed
                    )
                    gt = None
                    if isinstance(inputs, StoredView):  # the dataset's labels, as evaluate
                        gt = inputs.arrays["floor_label"].astype(np.float64)
                    elif not isinstance(inputs, dict):  # the truth at the input's points
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
                        if isinstance(run, ClassicalMethod):
                            metric = name == REFERENCE or get_corruption(name).preset.depth.metric
                            view = run.predict(
                                view_frame, inputs, cfg.robot, cfg.mount, config, metric
                            )
                        else:
                            view = predict_view(
                                run,
                                inputs,
                                cfg.robot,
                                descriptor,
                                config,
                                key,
                                cfg.target.is_articulated,
                            )
                        pred = view.pop("prediction", None)
                        if view_maps is not None and not records and model == next(iter(runs)):
                            view_maps[name] = pred if pred is not None else view
                        if pred is not None:
                            world_xy = base_to_world_xy(pred.poses[:, :2], episode.base_pose)
                            outcomes, stages = [], []
                            for x, y in world_xy:
                                at = (round(float(x), 4), round(float(y), 4))
                                if at not in trials:  # tried where chosen, as msr does
                                    trials[at] = runner.run(x, y)
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
