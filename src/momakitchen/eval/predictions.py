"""Predictions files: a method's maps scored without running it here, and the plain inputs
such a method reads.

A **predictions file** (``.npz``, or ``.h5`` / ``.hdf5`` with the same keys) holds, for
every episode of a split that has floor points, one 1-D float array under the key
``"{scene_id}/{config_index}/{episode_index}"``: the affordance in [0, 1] of each of the
episode's stored floor points, in the stored order (that of ``floor_xyz`` in the inputs
file). Other keys are ignored.

An **inputs file** (:func:`export_inputs`, same containers) holds, under the same episode
keys, what a method needs (``{key}/global_xyz`` ...; see :data:`INPUT_FIELDS`), plus
``descriptor_names`` (the columns of ``robot``) and ``format``. Both are read with NumPy
(``np.load``) or h5py alone.
"""

from __future__ import annotations

import os
import zipfile
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from momakitchen.errors import MomaError
from momakitchen.fileio import atomic_path, existing_file

NPZ_SUFFIXES = (".npz",)
HDF5_SUFFIXES = (".h5", ".hdf5")
INPUTS_FORMAT = "momakitchen-inputs-1"
# (name in the inputs file, stored field, dtype, meaning): every array is in the viewpoint
# robot's base frame (x forward, y left, z up, metres, z = 0 on the floor).
INPUT_FIELDS: tuple[tuple[str, str, str, str], ...] = (
    ("global_xyz", "global_xyz", "float32", "(Ng, 3) first-person cloud"),
    ("global_rgb", "global_rgb", "uint8", "(Ng, 3) its colour, 0-255"),
    ("global_align", "global_align", "int8", "(Ng,) +1 target, -1 obstacle, 0 other"),
    ("floor_xyz", "floor_xyz", "float32", "(Nf, 3) floor points to score, in this order"),
    ("robot", "descriptor", "float32", "(D,) robot descriptor (columns: descriptor_names)"),
    ("intrinsics", "intrinsics", "float64", "(4,) fx, fy, cx, cy of the 640x480 view"),
    ("camera_to_base", "camera_to_base", "float64", "(4, 4) OpenCV camera to base frame"),
)
IMAGE_FIELDS: tuple[tuple[str, str, str, str], ...] = (
    ("rgb", "rgb", "uint8", "(H, W, 3) colour image"),
    ("depth", "depth", "float32", "(H, W) metres along the optical axis, 0: no return"),
)


def episode_key(scene_id: int, config_index: int, episode_index: int) -> str:
    """The key of an episode in predictions and inputs files: ``"scene/config/episode"``."""
    return f"{int(scene_id)}/{int(config_index)}/{int(episode_index)}"


def split_episodes(
    manifest: dict[str, Any], split: str, configurations: Sequence[tuple[int, int]] | None = None
) -> list[tuple[str, int]]:
    """``(key, floor point count)`` of every episode with floor points of ``split``
    (``"all"``: both), or of the given ``(scene_id, config_index)`` pairs, in scene,
    configuration and episode order: the episodes a predictions file must cover."""
    wanted = None if configurations is None else {(int(s), int(c)) for s, c in configurations}
    out = []
    for sid in sorted(manifest["shards"], key=int):
        entry = manifest["shards"][sid]
        if wanted is None and split != "all" and entry["split"] != split:
            continue
        for c, counts in enumerate(entry["floor_points"]):
            if wanted is not None and (int(sid), c) not in wanted:
                continue
            out += [(episode_key(int(sid), c, e), int(n)) for e, n in enumerate(counts) if n > 0]
    return out


def dataset_episodes(data: Any) -> list[tuple[str, int]]:
    """``(key, floor point count)`` of every episode an
    :class:`~momakitchen.data.EpisodeDataset` serves, in its order: what a predictions file
    scored on it must cover."""
    shards = data.manifest["shards"]
    return [
        (episode_key(sid, c, e), int(shards[str(sid)]["floor_points"][c][e]))
        for _, sid, c, e, _ in data.index
    ]


def file_kind(path: Path) -> str:
    """``"npz"`` or ``"hdf5"`` by the suffix of ``path``; MomaError for another suffix."""
    suffix = path.suffix.lower()
    if suffix in NPZ_SUFFIXES:
        return "npz"
    if suffix in HDF5_SUFFIXES:
        return "hdf5"
    raise MomaError(f"{str(path)!r}: unknown file type {path.suffix!r}; use .npz, .h5 or .hdf5")


def read_predictions(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """Every array of a predictions file by key (``"scene/config/episode"``); MomaError
    naming the file when it is missing or unreadable. Values are not checked here (see
    :func:`check_predictions`)."""
    path = existing_file(path, "predictions file")
    kind = file_kind(path)
    try:
        if kind == "npz":
            with np.load(path, allow_pickle=False) as npz:
                return {k: np.asarray(npz[k]) for k in npz.files}
        import h5py

        out: dict[str, np.ndarray] = {}
        with h5py.File(path, "r") as f:

            def visit(name: str, obj: Any) -> None:
                if isinstance(obj, h5py.Dataset):
                    out[name] = np.asarray(obj[()])

            f.visititems(visit)
        return out
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        reason = " ".join(str(exc).split())[:120]
        raise MomaError(f"predictions file {str(path)!r} is unreadable ({reason})") from None


def check_predictions(
    maps: Mapping[str, np.ndarray], expected: Sequence[tuple[str, int]], path: str | os.PathLike
) -> None:
    """MomaError naming the first episode of ``expected`` (``(key, floor points)``, as from
    :func:`split_episodes`) whose map is missing, of another length or type, or holds NaN,
    infinite or out-of-[0, 1] values."""
    where = f"predictions file {str(path)!r}"
    for key, n in expected:
        if key not in maps:
            have = sum(k in maps for k, _ in expected)
            raise MomaError(
                f"{where} lacks episode {key!r} (it has {have} of the {len(expected)} "
                "episodes needed)"
            )
        a = maps[key]
        if a.dtype.kind not in "fiub":
            raise MomaError(f"{where}: episode {key!r} holds {a.dtype} values, not numbers")
        if a.shape != (n,):
            raise MomaError(
                f"{where}: episode {key!r} has shape {a.shape}, the episode has {n} floor "
                f"points: expected ({n},)"
            )
        values = a.astype(np.float64)
        if not np.isfinite(values).all():
            raise MomaError(f"{where}: episode {key!r} holds NaN or infinite values")
        if n and (values.min() < 0 or values.max() > 1):
            raise MomaError(
                f"{where}: episode {key!r} holds values outside [0, 1] (min "
                f"{values.min():.4g}, max {values.max():.4g})"
            )


@dataclass(frozen=True)
class Predictions:
    """A checked predictions file: the method's ``name`` and its map per episode key."""

    name: str
    path: Path
    maps: dict[str, np.ndarray]

    def map(self, scene_id: int, config_index: int, episode_index: int) -> np.ndarray:
        """The episode's affordance over its stored floor points. Shapes: (Nf,) float64."""
        return self.maps[episode_key(scene_id, config_index, episode_index)].astype(np.float64)


def method_name(path: str | os.PathLike, name: str | None = None) -> str:
    """The name a predictions file is reported under: ``name``, else the file's stem."""
    label = name if name is not None else Path(path).stem
    if not label or "/" in label:
        raise MomaError(f"method name must be non-empty and without '/', got {label!r}")
    return label


def load_predictions(
    path: str | os.PathLike, expected: Sequence[tuple[str, int]], name: str | None = None
) -> Predictions:
    """Read a predictions file and check it covers ``expected`` (see
    :func:`check_predictions`)."""
    maps = read_predictions(path)
    check_predictions(maps, expected, path)
    wanted = {k for k, _ in expected}
    return Predictions(method_name(path, name), Path(path), {k: maps[k] for k in wanted})


def write_predictions(path: str | os.PathLike, maps: Mapping[str, np.ndarray]) -> None:
    """Write maps by episode key as a predictions file (``.npz`` or ``.h5``; atomic)."""
    path = Path(path)
    write_arrays(path, ((k, np.asarray(v, np.float32)) for k, v in maps.items()), {})


def write_arrays(path: Path, arrays: Iterator[tuple[str, np.ndarray]], attrs: dict) -> None:
    """Stream ``(key, array)`` pairs into an ``.npz`` (zip of ``.npy``, compressed) or an
    HDF5 file (keys with ``/`` become groups), atomically; top-level ``attrs`` are stored
    as arrays (NPZ) or attributes (HDF5). Text is stored as NumPy unicode (NPZ) or UTF-8
    strings (HDF5)."""
    kind = file_kind(path)
    with atomic_path(path) as tmp:
        if kind == "npz":
            with zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_DEFLATED) as zf:
                for key, value in [*attrs.items(), *arrays]:
                    info = zipfile.ZipInfo(f"{key}.npy", date_time=(1980, 1, 1, 0, 0, 0))
                    info.compress_type = zipfile.ZIP_DEFLATED
                    with zf.open(info, "w", force_zip64=True) as fh:
                        np.lib.format.write_array(fh, np.asanyarray(value), allow_pickle=False)
        else:
            import h5py

            with h5py.File(tmp, "w") as f:
                for key, value in attrs.items():
                    f.attrs[key] = value.tolist() if value.dtype.kind == "U" else value
                for key, value in arrays:
                    if value.dtype.kind == "U":  # h5py stores text as UTF-8 strings
                        f.create_dataset(key, data=value.tolist(), dtype=h5py.string_dtype())
                    elif value.ndim == 0:
                        f.create_dataset(key, data=value)
                    else:
                        f.create_dataset(key, data=value, compression="gzip", compression_opts=1)


def export_inputs(
    root: str | os.PathLike, split: str, out: str | os.PathLike, images: bool = False
) -> int:
    """Write the inputs of every episode with floor points of ``split`` to ``out`` (see the
    module docstring; ``images``: also each view's ``rgb`` and ``depth``). Returns the
    number of episodes written."""
    from momakitchen.data import manifest as mf
    from momakitchen.data.integrity import check_shard_files
    from momakitchen.data.shard import SceneShard
    from momakitchen.robots.spec import DESCRIPTOR_NAMES

    root = Path(root)
    out = Path(out)
    file_kind(out)
    manifest = mf.load_manifest(root)
    episodes = split_episodes(manifest, split)
    if not episodes:
        raise MomaError(f"dataset {str(root)!r} has no {split} episodes with floor points")
    scenes = sorted({int(k.split("/")[0]) for k, _ in episodes})
    check_shard_files(root, manifest, set(scenes))
    fields = INPUT_FIELDS + (IMAGE_FIELDS if images else ())

    def arrays() -> Iterator[tuple[str, np.ndarray]]:
        for sid in scenes:
            entry = manifest["shards"][str(sid)]
            with SceneShard(root / entry["file"]) as shard:
                for key, _ in episodes:
                    s, c, e = (int(v) for v in key.split("/"))
                    if s != sid:
                        continue
                    stored = shard.arrays(c, e, [f for _, f, _, _ in fields])
                    for name, field, dtype, _ in fields:
                        yield f"{key}/{name}", np.asarray(stored[field], dtype)
                    yield f"{key}/robot_name", np.asarray(entry["robots"][c])

    attrs = {
        "format": np.asarray(INPUTS_FORMAT),
        "split": np.asarray(split),
        "descriptor_names": np.asarray(DESCRIPTOR_NAMES),
    }
    out.parent.mkdir(parents=True, exist_ok=True)  # once the inputs are known to be sound
    write_arrays(out, arrays(), attrs)
    return len(episodes)
