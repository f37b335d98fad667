"""Scene shards: one HDF5 file per scene holding its configurations and episodes.

Layout of ``scenes/scene_{scene_id:06d}.h5`` (schema ``SCHEMA_VERSION``)::

    /                               attrs: schema_version, generator_version, scene_id,
                                           num_configurations, num_episodes,
                                           descriptor_version, descriptor_names,
                                           semantic_classes, stage_names,
                                           complete (written last)
    /config_{c:03d}/                attrs: scene_id, config_index, robot, target,
                                           anchor (3,), num_episodes, feasible,
                                           mount_height (only where drawn)
        trial_positions (P, 2) f8   trial_yaws (P,) f8   trial_stages (P,) u1
        trial_moved (P,) f4
        episode_{e:03d}/            attrs: scene_id, config_index, episode_index, robot,
                                           base_pose (3,)
            rgb (H, W, 3) u1        depth (H, W) f4      semantic (H, W) u1
            intrinsics (4,) f8      camera_pose (4, 4) f8  camera_to_base (4, 4) f8
            descriptor (D,) f4      (D: the length of descriptor_version's layout)
            global_xyz (Ng, 3) f4   global_rgb (Ng, 3) u1  global_align (Ng,) i1
            floor_xyz (Nf, 3) f4    floor_label (Nf,) f4

Images and clouds are gzip-compressed (with the shuffle filter) in fixed chunks. Files are
written without timestamps and with a fixed order of groups, attributes and datasets, so
the same records always give the same bytes, whatever process writes them.

Writes are atomic: the shard is written to a hidden temporary file in the same directory,
the ``complete`` attribute is set last, the file is flushed, fsynced and renamed onto its
final name. Readers accept only files with the final name *and* the completion mark.

A shard written with an older robot descriptor version is read as a current one: its
descriptors gain the columns added since from the episode's robot (``SceneShard.arrays``).
"""

from __future__ import annotations

import hashlib
import os
import re
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from momakitchen.data.coverage import COVERAGE_RADIUS, sees_near
from momakitchen.data.episode import SEMANTIC_CLASSES, ConfigurationLabels, Episode
from momakitchen.errors import MomaError
from momakitchen.fileio import DISK_FULL, dumps_strict
from momakitchen.frames import float3
from momakitchen.robots.descriptor import upgrade_descriptor
from momakitchen.robots.spec import DESCRIPTOR_LAYOUTS, DESCRIPTOR_NAMES, DESCRIPTOR_VERSION
from momakitchen.sim.config import STAGE_NAMES
from momakitchen.version import __version__

# 2: labels of the routine with closed-loop pulls, maps zero where the base cannot stand,
# views that see floor near a success; configurations flagged feasible.
SCHEMA_VERSION = 2
SCENES_DIR = "scenes"
SHARD_PATTERN = re.compile(r"^scene_(\d{6,})\.h5$")
TMP_PREFIX = ".tmp-"
COMPRESSION = "gzip"
COMPRESSION_LEVEL = 1  # level 2 costs 16 % more time for 1.4 % smaller shards

SceneRecords = list[tuple[ConfigurationLabels, list[Episode]]]

# (field, dtype) of the per-episode datasets, in the order they are written.
EPISODE_ARRAYS: tuple[tuple[str, str], ...] = (
    ("rgb", "uint8"),
    ("depth", "float32"),
    ("semantic", "uint8"),
    ("intrinsics", "float64"),
    ("camera_pose", "float64"),
    ("camera_to_base", "float64"),
    ("descriptor", "float32"),
    ("global_xyz", "float32"),
    ("global_rgb", "uint8"),
    ("global_align", "int8"),
    ("floor_xyz", "float32"),
    ("floor_label", "float32"),
)
TRIAL_ARRAYS: tuple[tuple[str, str], ...] = (
    ("trial_positions", "float64"),
    ("trial_yaws", "float64"),
    ("trial_stages", "uint8"),
    ("trial_moved", "float32"),
)
# Arrays large enough to be worth compressing (the rest are stored contiguous).
_COMPRESSED = {
    "rgb",
    "depth",
    "semantic",
    "global_xyz",
    "global_rgb",
    "global_align",
    "floor_xyz",
    "floor_label",
}


def shard_name(scene_id: int) -> str:
    return f"scene_{int(scene_id):06d}.h5"


def config_key(config_index: int) -> str:
    return f"config_{int(config_index):03d}"


def episode_key(episode_index: int) -> str:
    return f"episode_{int(episode_index):03d}"


_IMAGES = {"rgb", "depth", "semantic"}


def _chunks(name: str, shape: tuple[int, ...]) -> tuple[int, ...]:
    """Fixed chunk shapes (bands of image rows, blocks of points): deterministic, and about
    64 k values each so reading one episode touches only its own chunks."""
    if name in _IMAGES:
        rows = max(1, min(shape[0], 65536 // max(1, int(np.prod(shape[1:])))))
        return (rows, *shape[1:])
    return (min(shape[0], 16384), *shape[1:])


def _put(group: h5py.Group, name: str, array: np.ndarray, dtype: str) -> None:
    arr = np.ascontiguousarray(np.asarray(array), dtype=dtype)
    if name in _COMPRESSED and arr.size > 0:
        group.create_dataset(
            name,
            data=arr,
            chunks=_chunks(name, arr.shape),
            compression=COMPRESSION,
            compression_opts=COMPRESSION_LEVEL,
            shuffle=True,
            track_times=False,
        )
    else:
        group.create_dataset(name, data=arr, track_times=False)


def _check_records(scene_id: int, records: SceneRecords) -> None:
    if not records:
        raise MomaError(f"scene {scene_id}: no configurations to write")
    for k, (labels, episodes) in enumerate(records):
        if labels.scene_id != scene_id or labels.config_index != k:
            raise MomaError(
                f"scene {scene_id}: configuration #{k} is labelled "
                f"{labels.scene_id}/{labels.config_index}"
            )
        for e, ep in enumerate(episodes):
            if (ep.scene_id, ep.config_index, ep.episode_index) != (scene_id, k, e):
                raise MomaError(
                    f"scene {scene_id} configuration {k}: episode #{e} is labelled "
                    f"{ep.scene_id}/{ep.config_index}/{ep.episode_index}"
                )
            ep.validate()


def sees_success(
    labels: ConfigurationLabels, floor_xyz: np.ndarray, base_pose: Sequence[float]
) -> bool:
    """Whether a view's floor cloud (N, 3) in its base frame ``base_pose`` comes within
    :data:`COVERAGE_RADIUS` of one of the configuration's successful trial positions."""
    return sees_near(floor_xyz, base_pose, labels.trial_positions[labels.trial_stages == 0])


def shard_summary(scene_id: int, records: SceneRecords) -> dict[str, Any]:
    """Counts of a scene's records (what the manifest keeps per shard)."""
    return {
        "scene_id": int(scene_id),
        "configurations": len(records),
        "episodes_per_config": [len(eps) for _, eps in records],
        "robots": [lab.robot for lab, _ in records],
        "targets": [lab.target for lab, _ in records],
        "trials": [int(lab.trial_stages.shape[0]) for lab, _ in records],
        "successes": [int(np.sum(lab.trial_stages == 0)) for lab, _ in records],
        "feasible": [bool(lab.feasible) for lab, _ in records],
        # Views that see floor within COVERAGE_RADIUS of a successful trial position.
        "covering_views": [
            sum(sees_success(lab, ep.floor_xyz, ep.base_pose) for ep in eps) for lab, eps in records
        ],
        # Per episode, so readers can skip empty clouds without opening files.
        "global_points": [[int(ep.global_xyz.shape[0]) for ep in eps] for _, eps in records],
        "floor_points": [[int(ep.floor_xyz.shape[0]) for ep in eps] for _, eps in records],
    }


def shard_bytes(scene_id: int, records: SceneRecords) -> bytes:
    """The bytes of a scene's shard, built in memory (HDF5's core driver): the same bytes
    as a file written by HDF5, but HDF5 never touches the disk, so a full disk is a plain
    ``OSError`` from :func:`write_shard_bytes` rather than a crash inside HDF5."""
    _check_records(scene_id, records)
    # libver pinned so the bytes do not depend on the HDF5 library's default.
    with h5py.File(
        shard_name(scene_id), "w", driver="core", backing_store=False, libver=("earliest", "v110")
    ) as f:
        _write_records(f, scene_id, records)
        f.flush()
        return bytes(f.id.get_file_image())


def write_shard(directory: str | os.PathLike, scene_id: int, records: SceneRecords) -> dict:
    """Write the records of one scene atomically to ``directory/scene_XXXXXX.h5``.

    Returns the shard summary (see :func:`shard_summary`) plus ``file``, ``bytes`` and
    ``sha256`` of the final file. A full disk is a MomaError naming the directory, with
    no temporary file left behind.
    """
    data = shard_bytes(scene_id, records)
    write_shard_bytes(directory, scene_id, data)
    return file_summary(scene_id, records, data)


def file_summary(scene_id: int, records: SceneRecords, data: bytes) -> dict:
    """:func:`shard_summary` plus ``file``, ``bytes`` and ``sha256`` of the shard ``data``."""
    summary = shard_summary(scene_id, records)
    summary.update(
        file=f"{SCENES_DIR}/{shard_name(scene_id)}",
        bytes=len(data),
        sha256=hashlib.sha256(data).hexdigest(),
    )
    return summary


def write_shard_bytes(directory: str | os.PathLike, scene_id: int, data: bytes) -> Path:
    """Atomically place a shard's bytes (:func:`shard_bytes`, possibly made elsewhere, e.g.
    on a Ray worker); MomaError naming the directory if the disk is full."""
    directory = Path(directory)
    final = directory / shard_name(scene_id)
    tmp = directory / f"{TMP_PREFIX}{os.getpid()}-{final.name}"
    try:
        _write_durably(tmp, data)
        os.replace(tmp, final)
        _fsync_dir(directory)
    except OSError as exc:
        if exc.errno in DISK_FULL:
            raise MomaError(
                f"cannot write shard {final.name} ({len(data) / 1e6:.1f} MB) to "
                f"{str(directory)!r}: {os.strerror(exc.errno)}; free some space and run "
                "the same command again to resume"
            ) from None
        raise
    finally:
        tmp.unlink(missing_ok=True)
    return final


def _write_durably(path: Path, data: bytes) -> None:
    """Write ``data`` to a new file ``path`` and make it reach the disk."""
    with open(path, "wb") as fh:
        fh.write(data)
        fh.flush()
        os.fsync(fh.fileno())


def _fsync_dir(directory: Path) -> None:
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:  # some platforms cannot open directories
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def _write_records(f: h5py.File, scene_id: int, records: SceneRecords) -> None:
    f.attrs["schema_version"] = SCHEMA_VERSION
    f.attrs["generator_version"] = __version__
    f.attrs["scene_id"] = int(scene_id)
    f.attrs["num_configurations"] = len(records)
    f.attrs["num_episodes"] = sum(len(eps) for _, eps in records)
    f.attrs["descriptor_version"] = DESCRIPTOR_VERSION
    f.attrs["descriptor_names"] = dumps_strict(list(DESCRIPTOR_NAMES))
    f.attrs["semantic_classes"] = dumps_strict(list(SEMANTIC_CLASSES))
    f.attrs["stage_names"] = dumps_strict(list(STAGE_NAMES))
    for labels, episodes in records:
        g = f.create_group(config_key(labels.config_index))
        g.attrs["scene_id"] = int(labels.scene_id)
        g.attrs["config_index"] = int(labels.config_index)
        g.attrs["robot"] = labels.robot
        g.attrs["target"] = labels.target
        g.attrs["anchor"] = np.asarray(labels.anchor, np.float64)
        g.attrs["num_episodes"] = len(episodes)
        g.attrs["feasible"] = int(labels.feasible)
        if labels.mount_height is not None:  # absent at the robot's own height
            g.attrs["mount_height"] = float(labels.mount_height)
        for name, dtype in TRIAL_ARRAYS:
            _put(g, name, getattr(labels, name), dtype)
        for ep in episodes:
            e = g.create_group(episode_key(ep.episode_index))
            e.attrs["scene_id"] = int(ep.scene_id)
            e.attrs["config_index"] = int(ep.config_index)
            e.attrs["episode_index"] = int(ep.episode_index)
            e.attrs["robot"] = ep.robot
            e.attrs["base_pose"] = np.asarray(ep.base_pose, np.float64)
            for name, dtype in EPISODE_ARRAYS:
                _put(e, name, getattr(ep, name), dtype)
    f.attrs["complete"] = 1  # last: a shard without it was never finished


def list_shards(root: str | os.PathLike) -> dict[int, Path]:
    """Final shard files under ``root/scenes`` by scene id (temporary files excluded)."""
    scenes = Path(root) / SCENES_DIR
    if not scenes.is_dir():
        return {}
    out: dict[int, Path] = {}
    for p in scenes.iterdir():
        m = SHARD_PATTERN.match(p.name)
        if m and p.is_file():
            out[int(m.group(1))] = p
    return dict(sorted(out.items()))


def remove_temporaries(root: str | os.PathLike) -> list[Path]:
    """Delete temporary shard files left by killed writers; return what was removed."""
    scenes = Path(root) / SCENES_DIR
    removed = []
    if scenes.is_dir():
        for p in sorted(scenes.iterdir()):
            # Every hidden file in scenes/ is a writer's temporary file.
            if p.name.startswith(".") and p.is_file():
                p.unlink(missing_ok=True)
                removed.append(p)
    return removed


def file_sha256(path: str | os.PathLike) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


class SceneShard:
    """Lazy reader of one scene shard. Arrays are read only when asked for.

    Opening checks the completion mark and the schema version; any failure is a
    :class:`MomaError` naming the file. Use as a context manager or call :meth:`close`.
    """

    def __init__(self, path: str | os.PathLike) -> None:
        self.path = Path(path)
        if self.path.name.startswith(TMP_PREFIX):
            raise MomaError(f"shard {self.path}: temporary file, not a finished shard")
        try:
            self._file = h5py.File(self.path, "r")
        except (OSError, ValueError) as exc:
            raise MomaError(f"shard {self.path}: cannot open ({_short(exc)})") from None
        attrs = self._file.attrs
        if int(attrs.get("complete", 0)) != 1:
            self.close()
            raise MomaError(f"shard {self.path}: incomplete (no completion mark)")
        version = int(attrs.get("schema_version", -1))
        if version != SCHEMA_VERSION:
            self.close()
            raise MomaError(
                f"shard {self.path}: schema version {version}, this reader "
                f"understands {SCHEMA_VERSION}"
            )
        self.scene_id = int(attrs["scene_id"])
        self.num_configurations = int(attrs["num_configurations"])
        self.num_episodes = int(attrs["num_episodes"])
        self.descriptor_version = int(attrs["descriptor_version"])
        if self.descriptor_version not in DESCRIPTOR_LAYOUTS:
            self.close()
            raise MomaError(
                f"shard {self.path}: robot descriptor version {self.descriptor_version}, "
                f"this reader understands {sorted(DESCRIPTOR_LAYOUTS)}"
            )

    def close(self) -> None:
        f = getattr(self, "_file", None)
        if f is not None:
            f.close()
            self._file = None

    def __enter__(self) -> SceneShard:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _group(self, *keys: str) -> h5py.Group:
        try:
            return self._file["/".join(keys)]
        except KeyError:
            raise MomaError(f"shard {self.path}: no group {'/'.join(keys)!r}") from None

    def config_indices(self) -> list[int]:
        return sorted(int(k.split("_")[1]) for k in self._file if k.startswith("config_"))

    def episode_indices(self, config_index: int) -> list[int]:
        g = self._group(config_key(config_index))
        return sorted(int(k.split("_")[1]) for k in g if k.startswith("episode_"))

    def covering(self, config_index: int, radius: float = COVERAGE_RADIUS) -> list[bool]:
        """Per view of the configuration, whether it sees floor within ``radius`` of a
        successful trial position (see :mod:`momakitchen.data.coverage`); reads only the
        floor clouds."""
        labels = self.configuration(config_index)
        successes = labels.trial_positions[labels.trial_stages == 0]
        return [
            sees_near(
                self.arrays(config_index, e, ("floor_xyz",))["floor_xyz"],
                self.episode_attrs(config_index, e)["base_pose"],
                successes,
                radius,
            )
            for e in self.episode_indices(config_index)
        ]

    def covering_views(self, config_index: int) -> int:
        """How many of the configuration's views see floor near a success."""
        return sum(self.covering(config_index))

    def configuration(self, config_index: int) -> ConfigurationLabels:
        g = self._group(config_key(config_index))
        a = g.attrs
        try:
            arrays = {name: np.asarray(g[name][()], dtype=dtype) for name, dtype in TRIAL_ARRAYS}
        except (OSError, KeyError) as exc:  # h5py's own text, shortened, after the file's name
            raise MomaError(
                f"shard {self.path}: configuration {config_index} unreadable ({_short(exc)})"
            ) from None
        return ConfigurationLabels(
            scene_id=int(a["scene_id"]),
            config_index=int(a["config_index"]),
            robot=_text(a["robot"]),
            target=_text(a["target"]),
            anchor=float3(a["anchor"]),
            mount_height=float(a["mount_height"]) if "mount_height" in a else None,
            **arrays,
        )

    def episode_attrs(self, config_index: int, episode_index: int) -> dict[str, Any]:
        e = self._group(config_key(config_index), episode_key(episode_index))
        return {k: e.attrs[k] for k in e.attrs}

    def num_points(self, config_index: int, episode_index: int) -> tuple[int, int]:
        """(global, floor) point counts of an episode (metadata only, no data read)."""
        e = self._group(config_key(config_index), episode_key(episode_index))
        return int(e["global_xyz"].shape[0]), int(e["floor_xyz"].shape[0])

    def arrays(
        self, config_index: int, episode_index: int, names: Sequence[str]
    ) -> dict[str, np.ndarray]:
        """Only the named per-episode arrays (e.g. the clouds, without the images); the
        descriptor always of the current version."""
        e = self._group(config_key(config_index), episode_key(episode_index))
        out = {}
        for name in names:
            if name not in e:
                raise MomaError(
                    f"shard {self.path}: episode {config_index}/{episode_index} "
                    f"has no dataset {name!r}"
                )
            try:
                out[name] = e[name][()]
            except OSError as exc:  # a damaged chunk: name the file, shorten h5py's text
                raise MomaError(
                    f"shard {self.path}: episode {config_index}/{episode_index} {name!r} "
                    f"unreadable ({_short(exc)})"
                ) from None
        if "descriptor" in out and self.descriptor_version != DESCRIPTOR_VERSION:
            robot = _text(e.attrs["robot"])
            try:
                out["descriptor"] = upgrade_descriptor(
                    out["descriptor"], self.descriptor_version, robot
                )
            except MomaError as exc:
                raise MomaError(
                    f"shard {self.path}: episode {config_index}/{episode_index}: {exc}"
                ) from None
        return out

    def episode(self, config_index: int, episode_index: int) -> Episode:
        e = self._group(config_key(config_index), episode_key(episode_index))
        a = e.attrs
        arrays = self.arrays(config_index, episode_index, [n for n, _ in EPISODE_ARRAYS])
        return Episode(
            scene_id=int(a["scene_id"]),
            config_index=int(a["config_index"]),
            episode_index=int(a["episode_index"]),
            robot=_text(a["robot"]),
            base_pose=float3(a["base_pose"]),
            **arrays,
        )

    def records(self) -> SceneRecords:
        """Everything in the shard, as the writer received it."""
        return [
            (self.configuration(c), [self.episode(c, e) for e in self.episode_indices(c)])
            for c in self.config_indices()
        ]

    def iter_episodes(self) -> Iterator[Episode]:
        for c in self.config_indices():
            for e in self.episode_indices(c):
                yield self.episode(c, e)


def _text(value: Any) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


def _short(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return text if len(text) < 160 else text[:157] + "..."
