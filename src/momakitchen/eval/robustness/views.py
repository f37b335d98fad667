"""The robustness track's views: which view of a configuration is judged, what a model is
given of it under each corruption, and a model's (or a predictions file's) prediction.

Two kinds of input (:func:`momakitchen.eval.robustness.run_robustness` uses both):

- ``clean`` is the view exactly as ``msr`` and ``evaluate`` score it: the episode's stored
  clouds (:class:`StoredView`, :func:`stored_view`), so the clean row of the track is
  ``msr``'s figure for the same views and settings;
- every other corruption is the stored render corrupted
  (:func:`~momakitchen.perception.sensors.corrupt_frame`) and made into clouds by the
  real-robot path (:func:`~momakitchen.perception.live.frame_inputs`, floor-plane
  correction included): :func:`view_inputs`.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from momakitchen.data.manifest import SPLIT_CHOICES
from momakitchen.errors import MomaError
from momakitchen.models.inference import PICK_RADIUS

# The row every other is compared with: msr's view of the configuration, as stored.
REFERENCE = "clean"
# Causes that leave no target to act on: the corrupted mask has no pixel of valid depth.
NO_TARGET = ("empty_mask", "no_target_depth")


@dataclass(frozen=True)
class RobustnessConfig:
    """Settings of a robustness run (those of ``msr`` where they mean the same, with the
    same defaults except ``top_k``).

    Attributes:
        corruptions: names from ``CORRUPTIONS`` (``clean`` first is the reference).
        top_k, min_spread, pick_radius: as ``MsrConfig``.
        seed: picks the same view per configuration as ``msr --seed``; also seeds the
            corruptions (with the episode and the corruption's name).
        split, max_configs: which configurations.
    """

    corruptions: tuple[str, ...] = (REFERENCE,)
    top_k: int = 1
    min_spread: float = 0.2
    pick_radius: float = PICK_RADIUS
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
        if self.split not in SPLIT_CHOICES:
            raise MomaError(f"split must be one of {SPLIT_CHOICES}, got {self.split!r}")


@dataclass(frozen=True)
class StoredView:
    """A view as ``msr`` and ``evaluate`` give it to a model: the episode's stored clouds
    in the viewpoint's base frame, nothing corrected (the track's ``clean`` input).

    Shapes: ``arrays`` holds ``global_xyz`` (Ng, 3), ``global_rgb`` (Ng, 3) uint8,
    ``global_align`` (Ng,), ``floor_xyz`` (Nf, 3), ``floor_label`` (Nf,) (the ground
    truth at those points) and ``descriptor`` (D,); ``target_xyz`` (3,) the median of the
    target's points (the configuration's target position where the view has none).
    ``episode_id`` seeds the clouds' down-sampling as ``msr`` and ``evaluate`` do.
    """

    arrays: dict[str, np.ndarray]
    episode_id: tuple[int, int, int]
    target_xyz: np.ndarray
    correction: None = None

    @property
    def floor_xyz(self) -> np.ndarray:
        """(Nf, 3) the floor points scored, in the stored order."""
        return self.arrays["floor_xyz"]

    def model_arrays(self) -> dict[str, np.ndarray]:
        """The cloud arrays a model is given (the labels left out)."""
        return {k: v for k, v in self.arrays.items() if k != "floor_label"}


def stored_view(episode: Any, anchor: Sequence[float]) -> StoredView:
    """A stored :class:`~momakitchen.data.episode.Episode` as :class:`StoredView`;
    ``anchor`` (3,) the target's world position (used only when no cloud point is the
    target's)."""
    from momakitchen.data.torch_dataset import CLOUD_FIELDS
    from momakitchen.frames import world_to_base

    arrays = {f: np.asarray(getattr(episode, f)) for f in CLOUD_FIELDS}
    target = arrays["global_align"] > 0
    if target.any():
        where = np.median(arrays["global_xyz"][target].astype(np.float64), axis=0)
    else:
        where = world_to_base(np.asarray([anchor], np.float64), episode.base_pose)[0]
    ids = (int(episode.scene_id), int(episode.config_index), int(episode.episode_index))
    return StoredView(arrays, ids, where)


def view_inputs(
    frame: Any, corruption_name: str, ids: tuple[int, int, int], preprocessing: Any, seed: int
) -> Any:
    """The real-robot input of one view under one corruption, the same for every model
    built with ``preprocessing``: a
    :class:`~momakitchen.perception.live.FrameClouds`, or the view's status
    (``{"status": "beyond_range" | "error", ...}``) when there is none. (``clean`` here is
    the clean render through the real-robot path; the track's clean row is
    :func:`stored_view`.)"""
    return corrupted_view(frame, corruption_name, ids, preprocessing, seed)[1]


def corrupted_view(
    frame: Any, corruption_name: str, ids: tuple[int, int, int], preprocessing: Any, seed: int
) -> tuple[Any, Any]:
    """The corrupted frame (None for a target beyond the sensor's range, which is not
    corrupted) and :func:`view_inputs`' result."""
    from momakitchen.perception.live import frame_inputs
    from momakitchen.perception.sensors import (
        corrupt_frame,
        corruption_rng,
        get_corruption,
        target_range,
    )

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
        if exc.fatal:  # a broken model, not a bad view: stop the run
            raise
        return bad, _error(exc)


def track_view(
    episode: Any,
    frame: Any,
    corruption_name: str,
    anchor: Sequence[float],
    preprocessing: Any,
    seed: int,
) -> tuple[Any, Any]:
    """One view's input in the track: ``(frame, input)``, the stored view for ``clean``
    (with the frame as rendered) and :func:`corrupted_view` for every other corruption."""
    if corruption_name == REFERENCE:
        return frame, stored_view(episode, anchor)
    ids = (int(episode.scene_id), int(episode.config_index), int(episode.episode_index))
    return corrupted_view(frame, corruption_name, ids, preprocessing, seed)


def _error(exc: MomaError) -> dict[str, Any]:
    return {"status": "error", "cause": exc.cause, "message": str(exc)}


def view_key(corruption: str, scene_id: int, config_index: int, episode_index: int) -> str:
    """A view's key in robustness inputs and predictions files:
    ``"corruption/scene/config/episode"``."""
    from momakitchen.eval.predictions import episode_key

    return f"{corruption}/{episode_key(scene_id, config_index, episode_index)}"


@dataclass(frozen=True)
class PredictionsMethod:
    """A method that ran elsewhere, as a robustness-track method: its map of each view's
    floor points (a predictions file keyed by :func:`view_key`, written from
    :func:`~momakitchen.eval.robustness.export_robustness_inputs`)."""

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
    opens: bool | None = None,
) -> dict[str, Any]:
    """One model (a loaded run, or a :class:`PredictionsMethod` with the view's ``key``)
    on one view's input (:func:`view_inputs` or :func:`stored_view`): ``{"status": "ok",
    "prediction": Prediction}``, or a copy of the view's status when it has no input.
    ``opens``: whether the robot opens the target (``predict_map``'s).

    A stored view is scored as ``msr`` scores it: its own descriptor, the down-sampling
    seeded by the episode, torch's threads as they are."""
    from momakitchen.models.inference import predict_map

    if isinstance(inputs, dict):
        return dict(inputs)
    if isinstance(run, PredictionsMethod):  # a bad file is the user's error, not the view's
        return {"status": "ok", "prediction": run.predict(key, inputs, robot, config)}
    stored = isinstance(inputs, StoredView)
    try:
        pred = predict_map(
            run,
            inputs.model_arrays() if stored else inputs,
            robot,
            inputs.arrays["descriptor"] if stored else descriptor,
            top_k=config.top_k,
            min_spread=config.min_spread,
            pick_radius=config.pick_radius,
            mc_samples=0,
            episode_id=inputs.episode_id if stored else None,
            threads=None if stored else 1,
            opens=opens,
        )
    except MomaError as exc:
        if exc.fatal:  # a broken model, not a bad view: stop the run
            raise
        return _error(exc)
    return {"status": "ok", "prediction": pred}


class ClassicalMethod:
    """A classical base-placement method (:func:`momakitchen.placement.place`) as a
    robustness-track method: it sees the view's frame (the corrupted one; for ``clean``
    the render as stored) and the robot at its mount, and its map is read at the view
    input's floor points (:func:`~momakitchen.placement.methods.map_at`), so that its
    poses, PCC and SIM are taken where a model's are."""

    def __init__(self, name: str) -> None:
        self.name = name

    def predict(
        self,
        frame: Any,
        inputs: Any,
        robot: str,
        mount: float,
        config: RobustnessConfig,
        metric: bool = True,
    ) -> dict[str, Any]:
        """``{"status": "ok", "prediction": Prediction}``, or the view's status when it
        has no input, or the method's error; ``metric`` False for depth known up to scale
        (a monocular corruption)."""
        from momakitchen.models.inference import map_prediction
        from momakitchen.placement.methods import map_at, place_frame

        if isinstance(inputs, dict):
            return dict(inputs)
        try:
            own = place_frame(self.name, frame, robot, mount_height=mount, metric_depth=metric)
        except MomaError as exc:
            return _error(exc)
        floor = np.asarray(inputs.floor_xyz, np.float64)
        scores = map_at(own, floor[:, :2])
        pred = map_prediction(
            floor,
            scores,
            np.zeros(len(floor)),
            inputs.target_xyz,
            robot,
            self.name,
            top_k=config.top_k,
            min_spread=config.min_spread,
            pick_radius=config.pick_radius,
            correction=getattr(inputs, "correction", None),
        )
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
    """One model on one corrupted view (the real-robot path, :func:`view_inputs`):
    ``{"status": "ok"|"beyond_range"|"error", ...}`` with the prediction
    (``prediction``) when ok."""
    preprocessing = None if run is None else run.preprocessing
    inputs = view_inputs(frame, corruption_name, ids, preprocessing, config.seed)
    return predict_view(run, inputs, robot, descriptor, config)


def judged_views(
    root: Path, todo: Iterable[tuple[int, int, str]], gen: Any, seed: int
) -> Iterator[tuple[Any, Any, int, int]]:
    """(scene, shard, config_index, episode_index) of the view ``msr`` judges for ``seed``
    in each configuration of ``todo`` that has one."""
    from momakitchen.data.reader import judged_view, rebuilt_configurations

    for scene, shard, ci in rebuilt_configurations(root, todo, gen.scene):
        ep = judged_view(shard, scene, ci, seed)
        if ep is not None:
            yield scene, shard, ci, ep
