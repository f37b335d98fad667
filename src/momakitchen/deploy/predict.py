"""Inference on a real robot's RGB-D frame: where should the base stop?

``predict`` turns one depth image (any resolution, any pinhole intrinsics), the camera's
pose in the robot base frame, a target mask (from the user's own segmenter) and the robot
into a navigation affordance map over the visible floor, the Top-k base poses and an
uncertainty estimate. The clouds are built by the same function as the dataset's
(:func:`momakitchen.perception.clouds.frame_clouds`), and the model runs through the
same collation and forward pass as ``momakitchen evaluate``.

Uncertainty: Monte-Carlo dropout. The map itself is the deterministic (eval-mode)
prediction; ``mc_samples`` extra forward passes with dropout active give a per-point
standard deviation. A robot can look again (or move closer) when the chosen point's
uncertainty is high or its affordance low.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any, Unpack

import numpy as np

from momakitchen.deploy.options import PredictFields, PredictOptions
from momakitchen.fileio import dumps_strict
from momakitchen.models.inference import Prediction
from momakitchen.perception.camera import Intrinsics

# The inputs are loaded and checked in perception, where the classical placement methods
# read them too; their names stay importable from here.
from momakitchen.perception.inputs import (
    MILLIMETRE_HINT,
    load_depth,
    load_extrinsics,
    load_frame,
    load_intrinsics,
    load_mask,
    load_rgb,
    robot_input,
)

__all__ = [
    "MILLIMETRE_HINT",
    "load_depth",
    "load_extrinsics",
    "load_intrinsics",
    "load_mask",
    "load_rgb",
    "predict",
    "robot_input",
    "write_outputs",
]


# ------------------------------------------------------------------------------ predict
def predict(
    depth: np.ndarray | str | os.PathLike,
    intrinsics: Sequence[float] | Any,
    camera_to_base: np.ndarray | str | os.PathLike,
    target_mask: np.ndarray | str | os.PathLike,
    robot: str | tuple[str, float] | Sequence[float] | Mapping[str, float] = "panda",
    *,
    rgb: np.ndarray | str | os.PathLike | None = None,
    obstacle_masks: Sequence[np.ndarray | str | os.PathLike] = (),
    checkpoint: str | os.PathLike | Any | None = None,
    episode_id: tuple[int, int, int] | None = None,
    options: PredictOptions | None = None,
    **fields: Unpack[PredictFields],
) -> Prediction:
    """Affordance map and Top-k base poses from one RGB-D frame.

    The calibrated ``camera_to_base`` is only a prior: the floor plane is fitted to the
    frame and the camera's height, pitch and roll corrected from it (reported in
    ``Prediction.correction``); the target is the depth-consistent part of its mask.

    Args:
        depth: (H, W) metres, or a ``.npy`` (metres) / 16-bit ``.png`` (millimetres) file;
            0 and NaN are invalid and ignored.
        intrinsics: ``(fx, fy, cx, cy)`` in pixels (OpenCV convention) or an
            :class:`~momakitchen.perception.camera.Intrinsics`.
        camera_to_base: (4, 4) rigid transform from the camera (x right, y down, z forward)
            to the robot base frame (x forward, y left, z up, z = 0 on the floor).
        target_mask: (H, W) mask of the target (e.g. from Grounded-SAM); non-zero = target.
        robot: a registered robot name, ``(name, mount_height)`` for it at another mount,
            or a descriptor (see :func:`robot_input`).
        rgb: optional (H, W, 3) image; without it the cloud is mid-grey.
        obstacle_masks: optional (H, W) masks of obstacles (chairs, bins, ...).
        checkpoint: a run directory (``momakitchen train``) or a loaded run; default: the
            bundled model.
        episode_id: ``(scene_id, config_index, episode_index)`` of a dataset episode, which
            seeds the cloud down-sampling exactly as ``evaluate`` does; None for live frames.
        options: how poses are ranked and returned (a
            :class:`~momakitchen.deploy.options.PredictOptions`; default: its defaults).
        **fields: any of its fields (``top_k``, ``min_spread``, ``pick_radius``,
            ``mc_samples``, ``threads``, ``metric_depth``, ``opens``), which override
            ``options``.
    """
    from momakitchen.models.inference import predict_map
    from momakitchen.perception.live import frame_inputs
    from momakitchen.train.checkpoint import LoadedRun, default_checkpoint, load_checkpoint

    opts = replace(options or PredictOptions(), **fields)  # checked by PredictOptions
    frame = load_frame(depth, intrinsics, camera_to_base, target_mask, obstacle_masks, rgb)
    name, descriptor = robot_input(robot)

    run = (
        checkpoint
        if isinstance(checkpoint, LoadedRun)
        else load_checkpoint(Path(checkpoint) if checkpoint is not None else default_checkpoint())
    )
    # The clouds are built as for the model's training data.
    clouds = frame_inputs(
        frame.depth,
        frame.valid,
        frame.rgb,
        frame.target_mask,
        list(frame.obstacle_masks),
        frame.intrinsics,
        frame.camera_to_base,
        run.preprocessing.cloud,
        run.preprocessing.max_depth,
        metric_depth=opts.metric_depth,
    )
    return predict_map(
        run,
        clouds,
        name,
        descriptor,
        top_k=opts.top_k,
        min_spread=opts.min_spread,
        pick_radius=opts.pick_radius,
        mc_samples=opts.mc_samples,
        episode_id=episode_id,
        threads=opts.threads,
        opens=opts.opens,
    )


def write_outputs(
    pred: Prediction,
    out_dir: str | os.PathLike,
    rgb: np.ndarray | None = None,
    depth: np.ndarray | None = None,
    intrinsics: Sequence[float] | Intrinsics | None = None,
    camera_to_base: np.ndarray | None = None,
) -> dict[str, Path]:
    """``prediction.json`` (poses and floor points) and ``prediction.png`` (top-down map and
    uncertainty, and the map over ``rgb`` (H, W, 3) when ``intrinsics`` and
    ``camera_to_base`` are given too, in the forms :func:`predict` takes). Inputs are
    checked before anything is written."""
    from momakitchen.fileio import atomic_write_bytes, atomic_write_text
    from momakitchen.perception.figures import prediction_figure

    if rgb is not None and intrinsics is not None:
        image, name = (rgb, "RGB image") if depth is None else (depth, "depth image")
        intrinsics = load_intrinsics(intrinsics, image.shape[:2], name)
    if camera_to_base is not None:
        camera_to_base = load_extrinsics(camera_to_base)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"json": out / "prediction.json", "png": out / "prediction.png"}
    atomic_write_text(paths["json"], dumps_strict(pred.to_dict(), indent=1) + "\n")
    atomic_write_bytes(
        paths["png"], prediction_figure(pred, rgb, depth, intrinsics, camera_to_base)
    )
    return paths
