"""The robustness track's inputs, written for a method that runs elsewhere
(``export-inputs --robustness``; the file format is in docs/METHODS.md)."""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from momakitchen.data.episode import episode_frame
from momakitchen.eval.robustness.views import (
    RobustnessConfig,
    StoredView,
    judged_views,
    track_view,
    view_key,
)

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
    exactly as :func:`~momakitchen.eval.robustness.run_robustness` gives it to a model
    (``clean``: the stored episode, as ``export-inputs`` writes it; every other
    corruption: through the real-robot path).

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
    from momakitchen.data.reader import dataset_generation, judged_configurations
    from momakitchen.eval.predictions import INPUT_FIELDS, file_kind, write_arrays
    from momakitchen.robots.descriptor import robot_descriptor
    from momakitchen.robots.spec import DESCRIPTOR_NAMES, get_robot_spec

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
            cfg = scene.configurations[ci]
            episode = shard.episode(ci, ep)
            frame = episode_frame(episode)
            descriptor = np.asarray(
                robot_descriptor(get_robot_spec(cfg.robot), cfg.mount_height), np.float32
            )
            for name in config.corruptions:
                key = view_key(name, sid, ci, ep)
                bad, inputs = track_view(
                    episode, frame, name, cfg.target.anchor, preprocessing, config.seed
                )
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
                stored = isinstance(inputs, StoredView)
                clouds = inputs.arrays if stored else inputs.arrays()
                fields = {
                    out_name: np.asarray(clouds[field], dtype)
                    for out_name, field, dtype, _ in INPUT_FIELDS
                    if field in clouds
                } | {
                    "target_xyz": np.asarray(inputs.target_xyz, np.float64),
                    # the stored view's own descriptor, as msr gives it to a model
                    "robot": np.asarray(clouds["descriptor"], np.float32) if stored else descriptor,
                    "intrinsics": np.asarray([k.fx, k.fy, k.cx, k.cy], np.float64),
                    "camera_to_base": np.asarray(bad.camera_to_base, np.float64),
                    "floor_correction": np.eye(4) if stored else inputs.correction.matrix,
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
                yield f"{key}/robot_name", np.asarray(cfg.robot)

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
