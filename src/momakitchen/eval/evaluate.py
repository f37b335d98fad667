"""Evaluation API: predictions for a batch, map metrics of a trained run or of a
predictions file (:mod:`momakitchen.eval.predictions`) on a dataset."""

from __future__ import annotations

from collections.abc import Iterator, Sized
from pathlib import Path
from typing import Any, cast

import numpy as np
from torch.utils.data import DataLoader, Dataset
from tqdm.auto import tqdm

from momakitchen.data.batch import episode_maps
from momakitchen.data.manifest import target_category
from momakitchen.errors import MomaError
from momakitchen.metrics import breakdown, map_metrics
from momakitchen.models.base import PlanningCollator
from momakitchen.models.inference import inference_collator, predict_batch
from momakitchen.train.checkpoint import (
    LoadedRun,
    check_preprocessing,
    dataset_preprocessing,
    load_checkpoint,
    run_label,
)


def evaluate(
    run_dir: str | Path,
    dataset: Dataset,
    batch_size: int = 8,
    num_workers: int = 1,
    progress: bool = False,
) -> dict[str, Any]:
    """Map metrics of the model in ``run_dir`` on every episode of ``dataset``.

    Global clouds are reduced to the run's ``num_global`` points as in training; every
    floor point of an episode is predicted, the floor encoded at the training density
    (``floor_context``: the run's ``num_floor`` points, see :func:`inference_collator`).
    ``num_workers`` DataLoader processes read and collate the episodes and find their
    geometry (:meth:`Backbone.plan`) while the model runs (0: all on this thread).

    Returns ``{"model", "preset", "episodes", "floor_context", "metrics", "per_robot",
    "per_scene"}`` (plus ``"per_category"`` when the dataset has a manifest naming each
    configuration's target) where ``metrics`` maps ``METRIC_NAMES`` to floats and the
    breakdowns map a robot name, scene id or target category to metrics plus an
    ``episodes`` count. A dataset whose manifest records other cloud preprocessing than the
    run was trained with is refused (MomaError).
    """
    if len(cast(Sized, dataset)) == 0:  # map-style datasets have a length
        raise MomaError("the evaluation dataset is empty")
    if batch_size < 1:
        raise MomaError(f"batch_size must be >= 1, got {batch_size}")
    run = load_checkpoint(run_dir)
    targets = _targets(getattr(dataset, "manifest", None))
    preds, gts, scenes, robots, configs = [], [], [], [], []
    for batch, p, g in predicted_maps(run, dataset, batch_size, num_workers, progress):
        preds += p
        gts += g
        scenes += list(batch["scene_id"])
        robots += list(batch["robot_name"])
        configs += list(zip(batch["scene_id"], batch["config_index"], strict=True))
    head = {"model": run_label(run), "preset": run.config.preset}
    return _report(head, run.config.num_floor, preds, gts, robots, scenes, configs, targets)


def predicted_maps(
    run: LoadedRun,
    dataset: Dataset,
    batch_size: int = 8,
    num_workers: int = 1,
    progress: bool = False,
) -> Iterator[tuple[dict[str, Any], list[np.ndarray], list[np.ndarray]]]:
    """The predicted and ground-truth map of every episode of ``dataset``, batch by batch,
    as ``evaluate`` scores them (the run's cloud down-sampling; every floor point).

    ``run`` comes from :func:`momakitchen.train.checkpoint.load_checkpoint`; a dataset
    preprocessed otherwise than its training data is refused (MomaError). Yields
    ``(batch, preds, labels)``: the collated batch and two lists of B arrays of shape
    (nf_i,) over each episode's real floor points.
    """
    root = getattr(dataset, "root", None)
    check_preprocessing(
        run,
        dataset_preprocessing(dataset),
        f"dataset {str(root)!r}" if root is not None else "dataset",
    )
    collate = PlanningCollator(inference_collator(run.config), run.model.backbone)
    loader = DataLoader(
        dataset, batch_size=batch_size, shuffle=False, collate_fn=collate, num_workers=num_workers
    )
    for batch in tqdm(loader, desc="evaluate", disable=not progress):
        if "floor_label" not in batch:
            raise MomaError("evaluation needs floor labels (floor_label) in every episode")
        yield (batch, *episode_maps(batch, predict_batch(run.model, batch)))


def evaluate_predictions(
    path: str | Path, data: Any, name: str | None = None, progress: bool = False
) -> dict[str, Any]:
    """Map metrics of a predictions file on every episode of ``data`` (an
    :class:`~momakitchen.data.EpisodeDataset`): the same report as :func:`evaluate`, with
    ``"model"`` the method's name (``name``, else the file's stem), ``"preset"``
    ``"predictions"`` and ``"floor_context"`` None. A file that lacks an episode, or whose
    map of one has another length, NaN or values outside [0, 1], is refused (MomaError
    naming the first such episode) before anything is scored."""
    from momakitchen.data.shard import SceneShard
    from momakitchen.eval.predictions import dataset_episodes, load_predictions

    index = list(data.index)
    if not index:
        raise MomaError("the evaluation dataset is empty")
    root = Path(data.root)
    method = load_predictions(path, dataset_episodes(data), name)
    targets = _targets(data.manifest)
    preds, gts, scenes, robots, configs = [], [], [], [], []
    shard: SceneShard | None = None
    try:
        for file, sid, c, e, robot in tqdm(index, desc="evaluate", disable=not progress):
            if shard is None or shard.path != root / file:
                if shard is not None:
                    shard.close()
                shard = SceneShard(root / file)
            gts.append(shard.arrays(c, e, ("floor_label",))["floor_label"].astype(np.float64))
            preds.append(method.map(sid, c, e))
            scenes.append(sid)
            robots.append(robot)
            configs.append((sid, c))
    finally:
        if shard is not None:
            shard.close()
    head = {"model": method.name, "preset": "predictions", "predictions": str(path)}
    return _report(head, None, preds, gts, robots, scenes, configs, targets)


def _report(
    head: dict[str, Any],
    floor_context: int | None,
    preds: list[np.ndarray],
    gts: list[np.ndarray],
    robots: list[str],
    scenes: list[int],
    configs: list[tuple[int, int]],
    targets: dict[tuple[int, int], str] | None,
) -> dict[str, Any]:
    """The report :func:`evaluate` and :func:`evaluate_predictions` return, from the
    per-episode maps (N arrays each) and their robots, scenes and configurations."""
    out = {
        **head,
        "episodes": len(preds),
        "floor_context": floor_context,
        "metrics": map_metrics(preds, gts),
        "per_robot": breakdown(preds, gts, robots),
        "per_scene": breakdown(preds, gts, scenes),
    }
    if targets is not None:
        out["per_category"] = breakdown(preds, gts, [targets[c] for c in configs])
    return out


def _targets(manifest: dict[str, Any] | None) -> dict[tuple[int, int], str] | None:
    """(scene id, configuration index) -> target category, from a dataset manifest's shard
    entries (None without a manifest, e.g. synthetic episodes)."""
    if manifest is None:
        return None
    return {
        (int(entry["scene_id"]), c): target_category(target)
        for entry in manifest["shards"].values()
        for c, target in enumerate(entry["targets"])
    }
