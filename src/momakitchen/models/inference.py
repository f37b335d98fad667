"""Running a trained model on one episode: the map, its uncertainty and the Top-k poses.

Shared by real-robot inference (:func:`momakitchen.predict`), the simulator demo and MSR,
so all three see the same clouds, collation and forward pass as ``momakitchen evaluate``.

Uncertainty: Monte-Carlo dropout. The map itself is the deterministic (eval-mode)
prediction; ``mc_samples`` extra forward passes with dropout active give a per-point
standard deviation.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
from scipy.spatial import cKDTree

from momakitchen.data.batch import EpisodeCollator
from momakitchen.data.torch_dataset import episode_sample
from momakitchen.errors import MomaError
from momakitchen.models.base import AffordanceModel
from momakitchen.models.reach_input import target_centroid
from momakitchen.perception.floor import FloorCorrection
from momakitchen.perception.live import FrameClouds

MC_SAMPLES = 8  # MC-dropout forward passes behind each uncertainty estimate
# Poses are ranked by the raw map (the paper's rule) unless a radius is given: averaging over
# 10 cm helped short runs on held-out train scenes but not the full-length models on the
# test scenes (docs/RESULTS.md), so it is an option, not the default.
PICK_RADIUS = 0.0
# The farthest target of the default training views (ViewConfig: 3.8 m ahead, 1.5 m
# aside), for runs that do not record theirs (LoadedRun.view_distance).
TRAINED_DISTANCE = math.hypot(3.8, 1.5)


@dataclass(frozen=True)
class Prediction:
    """The result of :func:`momakitchen.predict`, in the robot base frame (x forward, y left, z up).

    Shapes: ``floor_xyz`` (N, 3); ``affordance`` (N,) in [0, 1]; ``uncertainty`` (N,)
    (MC-dropout standard deviation; zeros without MC samples); ``poses`` (k, 3) rows
    ``x, y, yaw`` facing the target, best first; ``pose_scores`` and
    ``pose_uncertainty`` (k,); ``target_xyz`` (3,) the target's position (the median of
    its mask's depth-consistent points for a live frame); ``correction``: the floor-plane
    correction applied to the frame (None for stored episodes); ``warnings``: what the
    robot should know (a target farther than the training views).
    """

    floor_xyz: np.ndarray
    affordance: np.ndarray
    uncertainty: np.ndarray
    poses: np.ndarray
    pose_scores: np.ndarray
    pose_uncertainty: np.ndarray
    target_xyz: np.ndarray
    robot: str
    model: str
    correction: FloorCorrection | None = None
    warnings: tuple[str, ...] = ()

    def to_dict(self, floor_points: bool = True) -> dict[str, Any]:
        out: dict[str, Any] = {
            "frame": "robot base (x forward, y left, z up; metres, radians)",
            "robot": self.robot,
            "model": self.model,
            "target_xyz": [round(float(v), 4) for v in self.target_xyz],
            "target_distance_m": round(float(np.hypot(*self.target_xyz[:2])), 3),
            "floor_correction": None if self.correction is None else self.correction.to_dict(),
            "warnings": list(self.warnings),
            "poses": [
                {
                    "x": round(float(x), 4),
                    "y": round(float(y), 4),
                    "yaw": round(float(t), 4),
                    "affordance": round(float(s), 4),
                    "uncertainty": round(float(u), 4),
                }
                for (x, y, t), s, u in zip(
                    self.poses, self.pose_scores, self.pose_uncertainty, strict=True
                )
            ],
        }
        if floor_points:
            out["floor_points"] = {
                "columns": ["x", "y", "z", "affordance", "uncertainty"],
                "rows": np.round(
                    np.column_stack([self.floor_xyz, self.affordance, self.uncertainty]), 4
                ).tolist(),
            }
        return out


@torch.no_grad()
def predict_batch(model: AffordanceModel, batch: dict[str, Any]) -> torch.Tensor:
    """Affordance values of the floor points of a collated batch (eval mode, no labels used).

    Shapes:
        - input: a batch (see :mod:`momakitchen.data.batch`)
        - output: (B, Nf) in [0, 1]; 0 on padded floor points
    """
    was_training = model.training
    if was_training:  # switching modes walks every module: skip it when already in eval
        model.eval()
    unlabeled = {k: v for k, v in batch.items() if k != "floor_label"}
    try:
        return model(unlabeled)["pred"]
    finally:
        if was_training:
            model.train()


@contextmanager
def torch_threads(n: int | None) -> Iterator[None]:
    """Run the block with ``n`` torch intra-op threads (None: unchanged), then restore."""
    before = torch.get_num_threads()
    if n is not None and n != before:
        torch.set_num_threads(n)
    try:
        yield
    finally:
        if torch.get_num_threads() != before:
            torch.set_num_threads(before)


def inference_collator(config: Any) -> EpisodeCollator:
    """How a run's episodes are collated for inference (``config``: its TrainConfig): the
    global cloud reduced to ``num_global`` points as in training, every floor point
    predicted, and the floor encoded at the training density (``num_floor`` points, the
    ones training would have drawn; the rest are interpolated). Models trained on a
    sampled-down floor score a denser one worse when it is encoded whole. A model with a
    footprint gate gets each view's obstacle points from its whole cloud."""
    return EpisodeCollator(
        config.num_global,
        None,
        config.seed,
        num_context=config.num_floor,
        obstacles=config.model_config.footprint_gate,
    )


def run_model(
    run: Any, sample: dict[str, Any], mc_samples: int
) -> tuple[dict[str, Any], np.ndarray, np.ndarray]:
    """A loaded run on one sample, collated as ``evaluate`` does (every floor point): the
    batch, the map (Nf,) and its MC-dropout standard deviation (Nf,; zeros if
    ``mc_samples`` is 0)."""
    batch = inference_collator(run.config)([sample])
    affordance = predict_batch(run.model, batch)[0].numpy().astype(np.float64)
    std = mc_dropout_std(run.model, batch, mc_samples) if mc_samples else np.zeros_like(affordance)
    if not (np.isfinite(affordance).all() and np.isfinite(std).all()):
        raise NonFiniteOutput(getattr(run, "run_dir", "?"))
    return batch, affordance, std


class NonFiniteOutput(MomaError):
    """A model gave NaN or infinite affordances: its weights are broken (they overflow),
    whatever the input. Every prediction passes :func:`run_model`, so no map, pose or
    JSON document ever holds NaN."""

    fatal = True  # not one bad frame: a loop over frames stops

    def __init__(self, checkpoint: Any) -> None:
        self.checkpoint = checkpoint
        super().__init__(
            f"checkpoint {str(checkpoint)!r} gives non-finite affordances (NaN or infinity): "
            "its weights are broken or overflow; retrain it or use another checkpoint"
        )


def mc_dropout_std(model: Any, batch: dict[str, Any], samples: int) -> np.ndarray:
    """Per-floor-point standard deviation over ``samples`` predictions with dropout on
    (a fixed seed so the estimate is reproducible). Shapes: (Nf,)."""
    with torch.random.fork_rng():
        torch.manual_seed(0)
        preds = model.sample_predictions(batch, samples)
    return preds.std(0).numpy().astype(np.float64)


def local_mean(xy: np.ndarray, values: np.ndarray, radius: float) -> np.ndarray:
    """Each point's mean of ``values`` over the points within ``radius`` of it, itself
    included.

    Shapes: ``xy`` (N, 2), ``values`` (N,) -> (N,) float64
    """
    v = np.asarray(values, np.float64)
    n = len(v)
    pairs = cKDTree(np.asarray(xy, np.float64)).query_pairs(radius, output_type="ndarray")
    i, j = pairs[:, 0], pairs[:, 1]
    total = v + np.bincount(i, v[j], n) + np.bincount(j, v[i], n)
    count = 1.0 + np.bincount(i, minlength=n) + np.bincount(j, minlength=n)
    return total / count


def select_points(
    xy: np.ndarray,
    scores: np.ndarray,
    k: int,
    min_spread: float,
    accept: Callable[[int], bool] | None = None,
    radius: float = 0.0,
) -> list[int]:
    """Greedy Top-k: points in order of decreasing score (ties: lower index first), each
    kept if it is at least ``min_spread`` from those kept and ``accept(index)`` holds.
    With ``radius`` > 0 the order is that of the scores averaged over ``radius``
    (:func:`local_mean`), which favours the inside of a high region over a lone peak or
    its rim.

    Shapes: ``xy`` (N, 2), ``scores`` (N,); returns up to ``k`` indices, best first.
    """
    xy = np.asarray(xy)
    ranked = local_mean(xy, scores, radius) if radius > 0 else np.asarray(scores, np.float64)
    order = np.argsort(-ranked, kind="stable")
    # free[i]: i is at least min_spread from every kept point (updated as points are kept)
    free = np.ones(len(order), bool)
    kept: list[int] = []
    for i in order:
        i = int(i)
        if not free[i] or (accept is not None and not accept(i)):
            continue
        kept.append(i)
        if len(kept) == k:
            break
        free &= np.hypot(xy[:, 0] - xy[i, 0], xy[:, 1] - xy[i, 1]) >= min_spread
    return kept


def map_prediction(
    floor_xyz: np.ndarray,
    affordance: np.ndarray,
    uncertainty: np.ndarray,
    target: np.ndarray,
    robot: str,
    model: str,
    *,
    top_k: int,
    min_spread: float,
    pick_radius: float = PICK_RADIUS,
    correction: FloorCorrection | None = None,
    warnings: tuple[str, ...] = (),
) -> Prediction:
    """A map as a :class:`Prediction`: its Top-k floor points (:func:`select_points`)
    and the base poses there, facing the target.

    Shapes: ``floor_xyz`` (N, 3), ``affordance`` and ``uncertainty`` (N,), ``target`` (3,).
    """
    chosen = select_points(floor_xyz[:, :2], affordance, top_k, min_spread, radius=pick_radius)
    poses = np.array(
        [
            [
                floor_xyz[i, 0],
                floor_xyz[i, 1],
                math.atan2(target[1] - floor_xyz[i, 1], target[0] - floor_xyz[i, 0]),
            ]
            for i in chosen
        ]
    ).reshape(-1, 3)
    return Prediction(
        floor_xyz=floor_xyz,
        affordance=affordance,
        uncertainty=uncertainty,
        poses=poses,
        pose_scores=affordance[chosen],
        pose_uncertainty=uncertainty[chosen],
        target_xyz=target,
        robot=robot,
        model=model,
        correction=correction,
        warnings=warnings,
    )


def predict_map(
    run: Any,
    clouds: FrameClouds | dict[str, np.ndarray],
    robot: str,
    descriptor: np.ndarray,
    *,
    top_k: int = 5,
    min_spread: float = 0.2,
    pick_radius: float = PICK_RADIUS,
    mc_samples: int = MC_SAMPLES,
    episode_id: tuple[int, int, int] | None = None,
    threads: int | None = 1,
    opens: bool | None = None,
) -> Prediction:
    """The map of a loaded run (:func:`momakitchen.train.load_checkpoint`) over the floor
    points of ``clouds`` (:func:`~momakitchen.perception.live.frame_inputs`, or a stored
    episode's cloud arrays) and
    the Top-k base poses facing the target, ranked by the map averaged over
    ``pick_radius`` (m; 0: the raw map, see :func:`select_points`).

    ``episode_id`` seeds the cloud down-sampling exactly as ``evaluate`` does (None for
    live frames); ``threads``: torch threads while the model runs (None: unchanged);
    ``opens``: whether the robot opens the target rather than picking it (the sample's
    ``target_opens``; None: not said).
    """
    arrays = clouds.arrays() if isinstance(clouds, FrameClouds) else clouds
    f_xyz = arrays["floor_xyz"]
    ids = episode_id if episode_id is not None else (-1, -1, -1)
    sample = episode_sample({**arrays, "descriptor": descriptor}, *ids, robot, opens)
    with torch_threads(threads):
        batch, affordance, uncertainty = run_model(run, sample, mc_samples)
    if isinstance(clouds, FrameClouds):
        target = clouds.target_xyz
    else:
        target = (
            target_centroid(batch["global_xyz"], batch["global_align"], batch["global_mask"])[0]
            .numpy()
            .astype(np.float64)
        )
    distance = float(np.hypot(target[0], target[1]))
    warnings = []
    trained = getattr(run, "view_distance", None) or TRAINED_DISTANCE
    if distance > trained:
        warnings.append(
            f"the target is {distance:.2f} m away, farther than the model's training views "
            f"(up to {trained:.1f} m): move closer for a reliable map"
        )

    return map_prediction(
        f_xyz,
        affordance,
        uncertainty,
        target,
        robot,
        run.config.model,
        top_k=top_k,
        min_spread=min_spread,
        pick_radius=pick_radius,
        correction=clouds.correction if isinstance(clouds, FrameClouds) else None,
        warnings=tuple(warnings),
    )
