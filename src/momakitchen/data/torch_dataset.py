"""The HDF5-backed torch Dataset of episodes (samples of :mod:`momakitchen.data.batch`)."""

from __future__ import annotations

import os
from collections import OrderedDict
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch.utils.data import ConcatDataset, Dataset

from momakitchen.data import manifest as mf
from momakitchen.data.shard import SceneShard
from momakitchen.errors import MomaError
from momakitchen.robots.spec import DESCRIPTOR_DIM, DESCRIPTOR_LAYOUTS

# The stored arrays a model sample is made of.
CLOUD_FIELDS = (
    "descriptor",
    "global_xyz",
    "global_rgb",
    "global_align",
    "floor_xyz",
    "floor_label",
)


# The stored frame a noisy sample is rebuilt from, and what it keeps of the stored clouds
# (the global cloud is rebuilt; it is read only when the corrupted frame is unusable).
NOISE_FIELDS = ("depth", "rgb", "semantic", "intrinsics", "camera_to_base")
NOISE_KEEPS = ("descriptor", "floor_xyz", "floor_label")
# A rebuilt floor point takes the label of the nearest stored floor point within this
# distance (m); farther ones (floor the clean render did not show) are left out.
LABEL_RADIUS = 0.08


def noisy_sample(
    arrays: dict[str, np.ndarray], augmentation: Any, rng: np.random.Generator, preprocessing: Any
) -> dict[str, np.ndarray] | None:
    """An episode's cloud arrays as a robot with a random real sensor would give them to
    the model: the stored frame corrupted (:func:`~momakitchen.perception.sensors.corrupt_frame`
    with a draw of ``augmentation``) and rebuilt by the real-robot path
    (:func:`~momakitchen.perception.live.frame_inputs`, floor-plane correction included).
    The labels of the rebuilt floor points are those of the nearest stored floor points
    (the true affordance where the robot would drive), which the correction puts back
    in the true base frame. If the corrupted frame cannot be used (no target pixel left,
    no floor plane), returns None: the caller serves the clean arrays.

    Shapes: ``arrays`` holds ``NOISE_KEEPS`` and ``NOISE_FIELDS`` of one episode; returns
    ``CLOUD_FIELDS`` arrays.
    """
    from scipy.spatial import cKDTree

    from momakitchen.data.episode import stored_frame
    from momakitchen.perception.live import frame_inputs
    from momakitchen.perception.sensors import corrupt_frame

    frame = stored_frame(arrays)
    corruption = augmentation.draw(rng)
    bad = corrupt_frame(frame, corruption, rng)
    try:
        clouds = frame_inputs(
            bad.depth,
            bad.depth > 0,
            bad.rgb,
            bad.target_mask,
            list(bad.obstacle_masks),
            bad.intrinsics,
            bad.camera_to_base,
            preprocessing.cloud,
            preprocessing.max_depth,
            metric_depth=corruption.preset.depth.metric,
        )
    except MomaError:
        return None
    stored = arrays["floor_xyz"][:, :2].astype(np.float64)
    dist, near = cKDTree(stored).query(clouds.floor_xyz[:, :2], distance_upper_bound=LABEL_RADIUS)
    keep = np.isfinite(dist)
    if not keep.any():
        return None
    return {
        "descriptor": arrays["descriptor"],
        "global_xyz": clouds.global_xyz.astype(np.float32),
        "global_rgb": clouds.global_rgb,
        "global_align": clouds.global_align,
        "floor_xyz": clouds.floor_xyz[keep].astype(np.float32),
        "floor_label": arrays["floor_label"][near[keep]],
    }


def episode_sample(
    arrays: dict[str, np.ndarray],
    scene_id: int,
    config_index: int,
    episode_index: int,
    robot: str,
    opens: bool | None = None,
) -> dict[str, Any]:
    """A model sample (see :class:`EpisodeDataset`) from an episode's stored arrays
    (``CLOUD_FIELDS``; ``floor_label`` may be left out); ``opens``: whether the robot opens
    its target (``target_opens``; None: not said)."""
    sample: dict[str, Any] = {
        "global_xyz": torch.from_numpy(arrays["global_xyz"].astype(np.float32)),
        "global_rgb": torch.from_numpy(arrays["global_rgb"].astype(np.float32) / 255.0),
        "global_align": torch.from_numpy(arrays["global_align"].astype(np.float32)),
        "floor_xyz": torch.from_numpy(arrays["floor_xyz"].astype(np.float32)),
        "robot": torch.from_numpy(arrays["descriptor"].astype(np.float32)),
        "scene_id": scene_id,
        "config_index": config_index,
        "episode_index": episode_index,
        "robot_name": robot,
    }
    if "floor_label" in arrays:
        sample["floor_label"] = torch.from_numpy(arrays["floor_label"].astype(np.float32))
    if opens is not None:
        sample["target_opens"] = bool(opens)
    return sample


class EpisodeDataset(Dataset):
    """Episodes of a generated dataset, read lazily from its shards.

    The index (which episodes exist) comes from the manifest alone; shard files are opened
    on first use in each process (so ``DataLoader(num_workers=k)`` works: handles opened
    before a fork are dropped in the child) and kept in a small LRU cache.

    Args:
        root: dataset directory (with ``manifest.json``).
        split: ``"train"``, ``"test"`` or ``"all"``.
        robots: keep only configurations labelled with these robots (``None``: all).
        scene_ids: keep only these scenes (``None``: all of the split).
        transform: optional callable applied to each sample dict.
        max_open_files: shards kept open per process.
        skip_empty: leave out episodes without global or floor points (a view whose floor
            is entirely hidden); the collator cannot batch them.

    A sample (see :mod:`momakitchen.data.batch`): ``global_xyz`` (ng, 3), ``global_rgb``
    (ng, 3) in [0, 1], ``global_align`` (ng,), ``floor_xyz`` (nf, 3), ``floor_label`` (nf,)
    float32 tensors; ``robot`` (D,) float32 (the stored descriptor); ``scene_id``,
    ``config_index``, ``episode_index``, ``robot_name``; ``target_opens`` (from the
    manifest's target names). Batch them with
    :class:`~momakitchen.data.batch.EpisodeCollator`.
    """

    def __init__(
        self,
        root: str | os.PathLike,
        split: str = "train",
        *,
        robots: Sequence[str] | None = None,
        scene_ids: Sequence[int] | None = None,
        transform: Callable[[dict[str, Any]], dict[str, Any]] | None = None,
        max_open_files: int = 8,
        skip_empty: bool = True,
    ) -> None:
        if split not in mf.SPLIT_CHOICES:
            raise MomaError(f"split must be one of {mf.SPLIT_CHOICES}, got {split!r}")
        if max_open_files < 1:
            raise MomaError(f"max_open_files must be >= 1, got {max_open_files}")
        self.root = Path(root)
        self.manifest = mf.load_manifest(self.root)
        # Older descriptors are read as current ones (SceneShard.arrays).
        if self.manifest.get("descriptor_version") not in DESCRIPTOR_LAYOUTS:
            raise MomaError(
                f"{self.root}: robot descriptor version "
                f"{self.manifest.get('descriptor_version')!r}, this version of "
                f"momakitchen knows {sorted(DESCRIPTOR_LAYOUTS)}"
            )
        self.split = split
        self.transform = transform
        self.max_open_files = max_open_files
        wanted = None if scene_ids is None else {int(s) for s in scene_ids}
        robot_set = None if robots is None else set(robots)
        # (file, scene_id, config_index, episode_index, robot) of every selected episode.
        self.index: list[tuple[str, int, int, int, str]] = []
        # (scene_id, config_index) -> whether its robot opens the target.
        self.opens: dict[tuple[int, int], bool] = {}
        for key, entry in self.manifest["shards"].items():
            sid = int(key)
            if split != "all" and entry["split"] != split:
                continue
            if wanted is not None and sid not in wanted:
                continue
            for c, (n, robot) in enumerate(
                zip(entry["episodes_per_config"], entry["robots"], strict=True)
            ):
                if robot_set is not None and robot not in robot_set:
                    continue
                if c < len(entry.get("targets", ())):
                    self.opens[sid, c] = mf.target_opens(entry["targets"][c])
                for e in range(n):
                    if skip_empty and (
                        entry["global_points"][c][e] == 0 or entry["floor_points"][c][e] == 0
                    ):
                        continue
                    self.index.append((entry["file"], sid, c, e, robot))
        self._open: OrderedDict[str, SceneShard] = OrderedDict()
        self._pid = os.getpid()
        self.sensor_noise: Any = None
        self.preprocessing: Any = None
        self.noise_seed = 0
        self.epoch = 0

    def use_sensor_noise(self, augmentation: Any) -> None:
        """Serve every sample rebuilt from its stored RGB-D frame as a random real sensor,
        segmenter and calibration (``augmentation``, a
        :class:`~momakitchen.perception.sensors.SensorAugmentation`) would give it
        (:func:`noisy_sample`), drawn from ``(seed, epoch, scene, configuration,
        episode)`` (:meth:`set_epoch`). The stored data stay clean."""
        from momakitchen.data.config import manifest_preprocessing

        kitchen = self.manifest.get("producer") == mf.KITCHEN
        preprocessing = manifest_preprocessing(self.manifest) if kitchen else None
        if preprocessing is None:
            raise MomaError(
                f"{self.root}: sensor noise needs the RGB-D frames of a simulator-made "
                f"dataset (this one was made by {self.manifest.get('producer')!r})"
            )
        self.preprocessing = preprocessing
        self.sensor_noise = augmentation

    def set_epoch(self, epoch: int, seed: int = 0) -> None:
        """Draw the sensor noise of ``epoch`` (and ``seed``) from now on: each epoch sees
        every episode through another random sensor."""
        self.epoch, self.noise_seed = int(epoch), int(seed)

    def __len__(self) -> int:
        return len(self.index)

    def _shard(self, file: str) -> SceneShard:
        if self._pid != os.getpid():  # forked worker: never reuse the parent's handles
            self._open = OrderedDict()
            self._pid = os.getpid()
        shard = self._open.get(file)
        if shard is None:
            shard = SceneShard(self.root / file)
            self._open[file] = shard
            while len(self._open) > self.max_open_files:
                self._open.popitem(last=False)[1].close()
        else:
            self._open.move_to_end(file)
        return shard

    def __getitem__(self, i: int) -> dict[str, Any]:
        if not -len(self) <= i < len(self):
            raise IndexError(i)
        file, sid, c, e, robot = self.index[i]
        noisy = self.sensor_noise is not None
        shard = self._shard(file)
        a = shard.arrays(c, e, NOISE_KEEPS + NOISE_FIELDS if noisy else CLOUD_FIELDS)
        if a["descriptor"].shape != (DESCRIPTOR_DIM,):
            raise MomaError(f"{file} episode {c}/{e}: descriptor shape {a['descriptor'].shape}")
        if noisy:
            rng = np.random.default_rng([self.noise_seed, self.epoch, sid, c, e])
            rebuilt = noisy_sample(a, self.sensor_noise, rng, self.preprocessing)
            a = rebuilt if rebuilt is not None else shard.arrays(c, e, CLOUD_FIELDS)
        sample = episode_sample(a, sid, c, e, robot, self.opens.get((sid, c)))
        return self.transform(sample) if self.transform else sample

    def close(self) -> None:
        for shard in self._open.values():
            shard.close()
        self._open.clear()

    def __getstate__(self) -> dict[str, Any]:
        # Open HDF5 handles do not pickle (spawned DataLoader workers): reopen lazily.
        state = self.__dict__.copy()
        state["_open"] = OrderedDict()
        return state

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # interpreter shutdown
            pass


class EpisodeDatasets(ConcatDataset):
    """Several :class:`EpisodeDataset` read as one (``train --data A --data B``): their
    episodes in order, with sensor noise and the epoch's draw passed to each part."""

    def __init__(self, parts: Sequence[EpisodeDataset]) -> None:
        super().__init__(parts)
        self.parts = list(parts)

    def use_sensor_noise(self, augmentation: Any) -> None:
        for part in self.parts:
            part.use_sensor_noise(augmentation)

    def set_epoch(self, epoch: int, seed: int = 0) -> None:
        for part in self.parts:
            part.set_epoch(epoch, seed)
