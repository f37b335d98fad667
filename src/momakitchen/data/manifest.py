"""``manifest.json``: what a dataset is (producer, config, versions), its splits and counts.

The manifest is deterministic (no timestamps): the same generation gives the same file.
Splits are by scene: scene ids are cut into blocks of ``SPLIT_BLOCK`` consecutive ids and
one scene per block, chosen by a hash of the block index, goes to the unseen-scene test
set. That is exactly 20 % on whole blocks, independent of how many scenes are generated
and of the worker count, and a scene never changes split when the dataset grows.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections import Counter
from pathlib import Path
from typing import Any

from momakitchen.errors import MomaError
from momakitchen.fileio import atomic_write_text, dumps_strict, existing_dir
from momakitchen.robots.spec import DESCRIPTOR_NAMES, DESCRIPTOR_VERSION
from momakitchen.version import __version__

MANIFEST_NAME = "manifest.json"
MANIFEST_FORMAT = "momakitchen-dataset"
KITCHEN = "kitchen"  # the simulator-backed producer's name
SPLITS = ("train", "test")
# What a command reads of a dataset: one split, or both ("all").
SPLIT_CHOICES = (*SPLITS, "all")
# Keys of a shard entry (the writer's summary plus its split).
SHARD_KEYS = (
    "scene_id",
    "configurations",
    "episodes_per_config",
    "robots",
    "targets",
    "trials",
    "successes",
    "feasible",
    "covering_views",
    "global_points",
    "floor_points",
    "file",
    "bytes",
    "sha256",
    "split",
)
SPLIT_BLOCK = 5
SPLIT_RULE = (
    f"one scene in every block of {SPLIT_BLOCK} consecutive scene ids goes to test, "
    "chosen by sha256('momakitchen-split:<block>')"
)


def scene_split(scene_id: int) -> str:
    """``"train"`` or ``"test"`` for a scene (deterministic, about 80/20)."""
    if scene_id < 0:
        raise MomaError(f"scene_id must be >= 0, got {scene_id}")
    block = scene_id // SPLIT_BLOCK
    digest = hashlib.sha256(f"momakitchen-split:{block}".encode()).digest()
    chosen = int.from_bytes(digest[:8], "little") % SPLIT_BLOCK
    return "test" if scene_id % SPLIT_BLOCK == chosen else "train"


def scenes_for_both_splits(first_scene_id: int = 0) -> int:
    """The smallest ``--scenes`` from ``first_scene_id`` that gives both a train and a test
    scene (2 from scene 0: scene 0 is a test scene, scene 1 a train scene)."""
    seen: set[str] = set()
    sid = first_scene_id
    while len(seen) < len(SPLITS):
        seen.add(scene_split(sid))
        sid += 1
    return sid - first_scene_id


def new_manifest(
    producer: str,
    config: dict[str, Any],
    config_class: str = "",
    user_robots: list[dict[str, str]] | None = None,
) -> dict[str, Any]:
    """An empty manifest for a dataset made by ``producer`` with ``config`` (the plain data
    of an instance of ``config_class``) and the user robots ``user_robots`` (records
    ``{"name", "yaml", "sha256"}``; the key is left out when there are none)."""
    robots = {"user_robots": list(user_robots)} if user_robots else {}
    return {
        "format": MANIFEST_FORMAT,
        "schema_version": _schema_version(),
        "generator_version": __version__,
        "producer": producer,
        "config": config,
        "config_class": config_class,
        **robots,
        "descriptor_version": DESCRIPTOR_VERSION,
        "descriptor_names": list(DESCRIPTOR_NAMES),
        "split_rule": SPLIT_RULE,
        "complete": False,
        "splits": {s: [] for s in SPLITS},
        "counts": {},
        "shards": {},
    }


def _schema_version() -> int:
    from momakitchen.data.shard import SCHEMA_VERSION

    return SCHEMA_VERSION


def add_shard(manifest: dict[str, Any], summary: dict[str, Any], split: str | None = None) -> None:
    """Record a written shard (its summary from the writer) and its split."""
    sid = int(summary["scene_id"])
    split = split or scene_split(sid)
    if split not in SPLITS:
        raise MomaError(f"split must be one of {SPLITS}, got {split!r}")
    manifest["shards"][str(sid)] = {**summary, "split": split}


def finalize(manifest: dict[str, Any], complete: bool) -> dict[str, Any]:
    """Recompute splits and counts from the shard entries (sorted by scene id)."""
    shards = dict(sorted(manifest["shards"].items(), key=lambda kv: int(kv[0])))
    manifest["shards"] = shards
    manifest["splits"] = {s: [int(k) for k, v in shards.items() if v["split"] == s] for s in SPLITS}
    manifest["counts"] = compute_counts(shards.values())
    manifest["complete"] = bool(complete)
    return manifest


def target_category(target: str) -> str:
    """The category of a configuration's target: ``"fridge/door"`` -> ``"fridge"``."""
    return target.split("/")[0]


def target_opens(target: str) -> bool:
    """Whether the robot opens a configuration's target (an articulated part, named
    ``"fridge/door"``) rather than picking it (an object, ``"fruit"``)."""
    return "/" in target


def compute_counts(shards: Any) -> dict[str, Any]:
    """Scenes, configurations, episodes and trials per split, robot and target category."""
    counts: dict[str, Any] = {"total": _zero()}
    for s in SPLITS:
        counts[s] = _zero()
    by_robot: dict[str, dict[str, Counter]] = {}
    by_target: dict[str, dict[str, Counter]] = {}
    for sh in shards:
        split = sh["split"]
        for key in ("total", split):
            counts[key]["scenes"] += 1
        for robot, target, n_ep, n_tr, n_ok, n_cov in zip(
            sh["robots"],
            sh["targets"],
            sh["episodes_per_config"],
            sh["trials"],
            sh["successes"],
            sh["covering_views"],
            strict=True,
        ):
            category = target_category(target)
            for key in ("total", split):
                c = counts[key]
                c["configurations"] += 1
                c["episodes"] += n_ep
                c["trials"] += n_tr
                c["successful_trials"] += n_ok
                c["infeasible_configurations"] += int(n_ok == 0)
                if n_ok:  # coverage is a property of feasible configurations' views
                    c["feasible_views"] += n_ep
                    c["covering_views"] += n_cov
                for table, name in ((by_robot, robot), (by_target, category)):
                    row = table.setdefault(name, {k: Counter() for k in ("total", *SPLITS)})
                    row[key]["configurations"] += 1
                    row[key]["episodes"] += n_ep
                    row[key]["trials"] += n_tr
                    row[key]["successful_trials"] += n_ok
    counts["robots"] = {
        r: {k: dict(v) for k, v in row.items()} for r, row in sorted(by_robot.items())
    }
    counts["targets"] = {
        t: {k: dict(v) for k, v in row.items()} for t, row in sorted(by_target.items())
    }
    return counts


def _zero() -> dict[str, int]:
    return {
        "scenes": 0,
        "configurations": 0,
        "episodes": 0,
        "trials": 0,
        "successful_trials": 0,
        "infeasible_configurations": 0,
        "feasible_views": 0,
        "covering_views": 0,
    }


def requested_scene_ids(
    first_scene_id: int, num_scenes: int, split: str | None = None
) -> list[int]:
    """The ids ``first_scene_id .. first_scene_id + num_scenes - 1``, or only those of
    ``split`` (``"train"`` / ``"test"``, :func:`scene_split`)."""
    ids = range(first_scene_id, first_scene_id + num_scenes)
    return [s for s in ids if split is None or scene_split(s) == split]


def record_request(
    manifest: dict[str, Any], first_scene_id: int, num_scenes: int, split: str | None = None
) -> None:
    """Record the scenes a ``generate`` run was asked for (``check`` counts the missing).
    The split is recorded only when one was asked for, so a dataset made whole reads as
    if it had been made in one run."""
    manifest["requested"] = {"first_scene_id": int(first_scene_id), "num_scenes": int(num_scenes)}
    if split is not None:
        manifest["requested"]["split"] = split


def requested_ids(manifest: dict[str, Any]) -> list[int] | None:
    """Scene ids the last ``generate`` run asked for (those of its split, if it named one);
    None if the manifest does not record the request (written by an earlier version)."""
    req = manifest.get("requested")
    if not isinstance(req, dict):
        return None
    return requested_scene_ids(int(req["first_scene_id"]), int(req["num_scenes"]), req.get("split"))


def missing_scenes(manifest: dict[str, Any]) -> list[int] | None:
    """Requested scene ids (:func:`requested_ids`) that have no shard yet; None if the
    manifest does not record the request."""
    wanted = requested_ids(manifest)
    return None if wanted is None else [s for s in wanted if str(s) not in manifest["shards"]]


def split_checksum(manifest: dict[str, Any], split: str) -> str:
    """One SHA-256 over the checksums of a split's shards, in scene order: it names the
    exact bytes that evaluations on the split read (results made on other bytes, e.g. the
    same scenes generated on another CPU, are not reused). ``split`` "all": every shard."""
    if split not in (*SPLITS, "all"):
        raise MomaError(f"unknown split {split!r}; splits: {', '.join(SPLITS)}, all")
    shards = manifest["shards"]
    sums = [
        shards[k]["sha256"]
        for k in sorted(shards, key=int)
        if split == "all" or shards[k]["split"] == split
    ]
    return hashlib.sha256(" ".join(sums).encode()).hexdigest()


def manifest_path(root: str | os.PathLike) -> Path:
    return Path(root) / MANIFEST_NAME


def load_manifest(root: str | os.PathLike) -> dict[str, Any]:
    """Read ``root/manifest.json``; MomaError if the root or manifest is missing/malformed."""
    root = existing_dir(root, "dataset directory")
    path = manifest_path(root)
    if not path.is_file():
        raise MomaError(f"{str(root)!r} is not a momakitchen dataset (no {MANIFEST_NAME})")
    try:
        data = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise MomaError(f"{path}: malformed manifest ({exc})") from None
    if not isinstance(data, dict) or data.get("format") != MANIFEST_FORMAT:
        raise MomaError(f"{path}: not a momakitchen dataset manifest")
    for key in ("schema_version", "producer", "config", "splits", "shards"):
        if key not in data:
            raise MomaError(f"{path}: manifest has no {key!r}")
    if data["schema_version"] != _schema_version():
        # Another schema: its labels or layout differ (docs/DATASET.md), so say so first.
        raise MomaError(
            f"{path}: dataset schema version {data['schema_version']} (written by "
            f"momakitchen {data.get('generator_version', '?')}), this version of momakitchen "
            f"reads {_schema_version()}: generate the dataset again"
        )
    if not isinstance(data["shards"], dict):
        raise MomaError(f"{path}: 'shards' must be an object")
    for key, entry in data["shards"].items():
        missing = [k for k in SHARD_KEYS if not isinstance(entry, dict) or k not in entry]
        if missing:
            raise MomaError(f"{path}: shard entry {key!r} lacks {missing[0]!r}")
    return _current_names(data)


def manifest_user_robots(
    manifest: dict[str, Any], root: str | os.PathLike = "dataset"
) -> list[dict[str, str]]:
    """The user robots a dataset was labelled with (``{"name", "yaml", "sha256"}``
    records; empty for built-in robots only); MomaError on a malformed entry."""
    from momakitchen.robots.user import UserRobotFile

    records = manifest.get("user_robots", [])
    if not isinstance(records, list):
        raise MomaError(f"{root}: manifest 'user_robots' must be a list, got {records!r}")
    where = f"{root}: manifest 'user_robots' entry"
    return [UserRobotFile.from_dict(r, where).to_dict() for r in records]


def check_user_robots(manifest: dict[str, Any], root: str | os.PathLike) -> None:
    """MomaError (one line) unless every user robot the dataset at ``root`` was labelled
    with is registered here from the same contents (``--robot-yaml`` /
    ``MOMAKITCHEN_ROBOT_YAML``): what rebuilding its worlds needs."""
    from momakitchen.robots.user import UserRobotFile, recorded_robot_problem

    for record in manifest_user_robots(manifest, root):
        problem = recorded_robot_problem(
            UserRobotFile.from_dict(record), f"dataset {str(root)!r} was labelled with"
        )
        if problem:
            raise MomaError(problem)


def save_manifest(root: str | os.PathLike, manifest: dict[str, Any]) -> None:
    atomic_write_text(manifest_path(root), dumps_strict(manifest, indent=1) + "\n")


# Config classes that :func:`generation_config` may rebuild (never an arbitrary import).
_CONFIG_CLASSES = {
    "momakitchen.data.config.GenerationConfig": ("momakitchen.data.config", "GenerationConfig"),
    "momakitchen.data.synthetic_scene.SyntheticSceneConfig": (
        "momakitchen.data.synthetic_scene",
        "SyntheticSceneConfig",
    ),
}
# Names that manifests written by earlier versions use, and what they are called now.
LEGACY_NAMES = {
    "producer": {"momakitchen.perception.episodes.scene_records": KITCHEN},
    "config_class": {
        "momakitchen.perception.episodes.GenerationConfig": (
            "momakitchen.data.config.GenerationConfig"
        )
    },
}


def _current_names(manifest: dict[str, Any]) -> dict[str, Any]:
    """``manifest`` with the producer and config class under their current names."""
    for key, renamed in LEGACY_NAMES.items():
        if manifest.get(key) in renamed:
            manifest[key] = renamed[manifest[key]]
    return manifest


def generation_config(manifest: dict[str, Any], root: str | os.PathLike = "dataset") -> Any:
    """The config object a dataset (at ``root``, for messages) was generated with (e.g. to
    rebuild its worlds: ``sample_scene(scene_id, generation_config(m).scene)``); MomaError
    if unknown, or if a user robot it names is not registered (:func:`check_user_robots`)."""
    import importlib

    from momakitchen import codec

    name = manifest.get("config_class", "")
    if name not in _CONFIG_CLASSES:
        raise MomaError(f"cannot rebuild generation config of class {name!r}")
    check_user_robots(manifest, root)
    module, cls_name = _CONFIG_CLASSES[name]
    cls = getattr(importlib.import_module(module), cls_name)
    return codec.from_dict(cls, manifest["config"], where="config")
