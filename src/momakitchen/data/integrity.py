"""Integrity check and statistics of a dataset on disk."""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from momakitchen.data import manifest as mf
from momakitchen.data.config import manifest_preprocessing
from momakitchen.data.episode import SEMANTIC_CLASSES
from momakitchen.data.shard import EPISODE_ARRAYS, SceneShard, file_sha256, list_shards
from momakitchen.errors import MomaError
from momakitchen.robots.spec import DESCRIPTOR_DIM
from momakitchen.sim.config import STAGE_NAMES

# Floor points are those below 2 cm (docs/DESIGN.md §3.4) unless the manifest's generation
# config says otherwise (cloud.floor_z).
FLOOR_Z_MAX = 0.02


def floor_z_max(manifest: dict[str, Any]) -> float:
    """The floor-height threshold a dataset's clouds were built with: the manifest's
    ``config.cloud.floor_z``, or :data:`FLOOR_Z_MAX` if the producer records none."""
    preprocessing = manifest_preprocessing(manifest)
    return preprocessing.cloud.floor_z if preprocessing is not None else FLOOR_Z_MAX


def _shard_entries(root: Path, manifest: dict[str, Any]) -> list[tuple[int, dict, Path]]:
    """(scene id, manifest entry, path) for every shard; MomaError on a missing/extra file."""
    files = list_shards(root)
    entries = []
    for key, entry in manifest["shards"].items():
        sid = int(key)
        path = root / entry.get("file", "")
        if sid not in files or files[sid] != path:
            raise MomaError(f"shard {entry.get('file')} listed in the manifest is missing")
        entries.append((sid, entry, path))
    extra = sorted(set(files) - {sid for sid, _, _ in entries})
    if extra:
        raise MomaError(
            f"shard {files[extra[0]].relative_to(root)} is not in the manifest "
            "(an interrupted run? run 'momakitchen generate' again to finish it)"
        )
    return entries


def _check_episode(
    shard: SceneShard, c: int, e: int, where: str, floor_z: float = FLOOR_Z_MAX
) -> int:
    """Validate one episode's arrays (floor points below ``floor_z``); return its global +
    floor point count."""
    ep = shard.episode(c, e)
    if (ep.scene_id, ep.config_index, ep.episode_index) != (shard.scene_id, c, e):
        raise MomaError(f"{where}: identity attributes do not match its position")
    ep.validate()
    finite = {
        n: bool(np.all(np.isfinite(getattr(ep, n))))
        for n, t in EPISODE_ARRAYS
        if t.startswith("float")
    }
    bad = [n for n, ok in finite.items() if not ok]
    if bad:
        raise MomaError(f"{where}: non-finite values in {bad}")
    if ep.depth.size and float(ep.depth.min()) < 0:
        raise MomaError(f"{where}: negative depth {float(ep.depth.min())}")
    if ep.semantic.size and int(ep.semantic.max()) >= len(SEMANTIC_CLASSES):
        raise MomaError(f"{where}: semantic class {int(ep.semantic.max())} out of range")
    if ep.descriptor.shape != (DESCRIPTOR_DIM,):
        raise MomaError(
            f"{where}: descriptor shape {ep.descriptor.shape}, expected ({DESCRIPTOR_DIM},)"
        )
    if ep.floor_xyz.size and float(ep.floor_xyz[:, 2].max()) >= floor_z + 1e-6:
        raise MomaError(
            f"{where}: floor point at z = {float(ep.floor_xyz[:, 2].max()):.4f} m >= {floor_z}"
        )
    return ep.global_xyz.shape[0] + ep.floor_xyz.shape[0]


def _open_checked(
    sid: int, entry: dict[str, Any], path: Path, verify_hash: bool = False
) -> tuple[SceneShard, list[int], list[int]]:
    """Open a shard after checking it against its manifest entry: there, of the recorded
    size (and checksum with ``verify_hash``), complete, of this schema and a known
    descriptor version (older ones are read as current), holding the recorded scene,
    configurations and episodes (metadata only: a few ms). Returns the open shard, its
    configuration indices and episodes per configuration; MomaError naming the shard
    otherwise."""
    name = entry["file"]
    if not path.is_file():
        raise MomaError(f"shard {name} listed in the manifest is missing")
    if path.stat().st_size != entry["bytes"]:
        raise MomaError(
            f"shard {name}: {path.stat().st_size} bytes, the manifest says "
            f"{entry['bytes']} (truncated or replaced)"
        )
    if verify_hash and file_sha256(path) != entry["sha256"]:
        raise MomaError(f"shard {name}: checksum differs from the manifest (corrupt)")
    try:
        shard = SceneShard(path)
    except MomaError as exc:
        raise MomaError(f"shard {name}: {str(exc).split(': ', 1)[-1]}") from None
    try:
        if shard.scene_id != sid:
            raise MomaError(f"shard {name}: holds scene {shard.scene_id}")
        try:
            configs = shard.config_indices()
            per_config = [len(shard.episode_indices(c)) for c in configs]
        except (OSError, KeyError, ValueError) as exc:
            raise MomaError(f"shard {name}: unreadable ({exc})") from None
        if (
            configs != list(range(entry["configurations"]))
            or per_config != entry["episodes_per_config"]
        ):
            raise MomaError(
                f"shard {name}: {len(configs)} configurations / {per_config} "
                f"episodes, the manifest says {entry['configurations']} / "
                f"{entry['episodes_per_config']}"
            )
    except BaseException:
        shard.close()
        raise
    return shard, configs, per_config


def check_shard_files(
    root: str | os.PathLike,
    manifest: dict[str, Any],
    scene_ids: Iterable[int] | None = None,
    verify_hash: bool = False,
) -> None:
    """The quick check that ``evaluate``, ``train`` and ``msr`` run on the shards they will
    read (``scene_ids``; None: all in the manifest) before any work: each is there, has
    the size the manifest records, opens as a finished shard and holds the recorded scene,
    configurations and episodes; with ``verify_hash`` its SHA-256 is the manifest's too (a
    byte flipped anywhere; about 1 s per GB). MomaError naming the first bad shard
    (``check`` also verifies every array)."""
    root = Path(root)
    wanted = None if scene_ids is None else {int(s) for s in scene_ids}
    for key, entry in manifest["shards"].items():
        if wanted is None or int(key) in wanted:
            try:
                shard, _, _ = _open_checked(int(key), entry, root / entry["file"], verify_hash)
            except MomaError as exc:
                raise MomaError(f"{root}: {exc}; run `momakitchen check {root}`") from None
            shard.close()


def check_shard(
    root: Path,
    sid: int,
    entry: dict[str, Any],
    path: Path,
    verify_hash: bool = True,
    floor_z: float = FLOOR_Z_MAX,
) -> int:
    """Check one shard against its manifest entry (floor points below ``floor_z``); return
    its episode count."""
    name = entry["file"]
    shard, configs, per_config = _open_checked(sid, entry, path, verify_hash)
    with shard:
        for c in configs:
            where = f"shard {name} configuration {c}"
            lab = shard.configuration(c)
            if lab.robot != entry["robots"][c] or lab.target != entry["targets"][c]:
                raise MomaError(f"{where}: robot/target differ from the manifest")
            p = lab.trial_positions.shape[0]
            if (
                lab.trial_positions.shape != (p, 2)
                or lab.trial_yaws.shape != (p,)
                or lab.trial_stages.shape != (p,)
                or lab.trial_moved.shape != (p,)
            ):
                raise MomaError(f"{where}: trial arrays of inconsistent shapes")
            if not (
                np.all(np.isfinite(lab.trial_positions))
                and np.all(np.isfinite(lab.trial_yaws))
                and np.all(np.isfinite(lab.trial_moved))
            ):
                raise MomaError(f"{where}: non-finite trial values")
            if p and int(lab.trial_stages.max()) >= len(STAGE_NAMES):
                raise MomaError(f"{where}: trial stage {int(lab.trial_stages.max())} out of range")
            if int((lab.trial_stages == 0).sum()) != entry["successes"][c]:
                raise MomaError(f"{where}: success count differs from the manifest")
            if lab.feasible != bool(entry["feasible"][c]):
                raise MomaError(f"{where}: feasibility flag differs from the manifest")
            for e in shard.episode_indices(c):
                if list(shard.num_points(c, e)) != [
                    entry["global_points"][c][e],
                    entry["floor_points"][c][e],
                ]:
                    raise MomaError(
                        f"shard {name} episode {c}/{e}: point counts differ from the manifest"
                    )
                try:
                    _check_episode(shard, c, e, f"shard {name} episode {c}/{e}", floor_z)
                except (OSError, KeyError, ValueError) as exc:
                    if isinstance(exc, MomaError):
                        raise
                    raise MomaError(f"shard {name} episode {c}/{e}: unreadable ({exc})") from None
    return sum(per_config)


def check_dataset(
    root: str | os.PathLike,
    *,
    verify_hash: bool = True,
    progress: Callable[[int, int], None] | None = None,
) -> dict[str, Any]:
    """Check every shard (opens, checksum, counts, finite in-range arrays) and the totals.

    Raises MomaError naming the first bad shard; returns ``{"shards", "episodes"}``.
    """
    root = Path(root)
    manifest = mf.load_manifest(root)
    entries = _shard_entries(root, manifest)
    floor_z = floor_z_max(manifest)
    episodes = 0
    for i, (sid, entry, path) in enumerate(entries):
        episodes += check_shard(root, sid, entry, path, verify_hash, floor_z)
        if progress:
            progress(i + 1, len(entries))
    _check_counts(root, manifest.get("counts", {}), mf.compute_counts(e for _, e, _ in entries))
    expected = manifest.get("counts", {}).get("total", {}).get("episodes")
    if expected != episodes:
        raise MomaError(f"manifest counts {expected} episodes, the shards hold {episodes}")
    for split in mf.SPLITS:
        listed = sorted(manifest["splits"].get(split, []))
        actual = sorted(sid for sid, e, _ in entries if e["split"] == split)
        if listed != actual:
            raise MomaError(f"manifest split {split!r} does not match its shard entries")
    return {
        "shards": len(entries),
        "episodes": episodes,
        "complete": manifest["complete"],
        "incomplete": incomplete_note(manifest),
    }


def incomplete_note(manifest: dict[str, Any]) -> str:
    """How unfinished a dataset is, for messages ("generation incomplete: 1 of 20 requested
    scenes missing"); "" when its generation is complete."""
    if manifest["complete"]:
        return ""
    missing = mf.missing_scenes(manifest)
    if missing is None:
        return "generation incomplete (the manifest does not record how many scenes are missing)"
    return (
        f"generation incomplete: {len(missing)} of {len(mf.requested_ids(manifest) or ())} "
        "requested scenes missing"
    )


def dataset_stats(root: str | os.PathLike) -> dict[str, Any]:
    """Counts per split / robot / target category, success rates, sizes (reads metadata,
    point-count shapes and floor labels only)."""
    root = Path(root)
    manifest = mf.load_manifest(root)
    entries = _shard_entries(root, manifest)
    counts = manifest["counts"]
    _check_counts(root, counts, mf.compute_counts(e for _, e, _ in entries))
    total_bytes = 0
    points: dict[str, list[int]] = {"global": [], "floor": []}
    label_mean: list[float] = []
    label_pos: list[float] = []
    image_shape = None
    for _sid, entry, path in entries:
        total_bytes += path.stat().st_size
        try:
            shard = SceneShard(path)
        except MomaError as exc:
            raise MomaError(f"shard {entry['file']}: {str(exc).split(': ', 1)[-1]}") from None
        with shard:
            try:
                per_config = [len(shard.episode_indices(c)) for c in shard.config_indices()]
                if per_config != entry["episodes_per_config"]:
                    raise MomaError(
                        f"shard {entry['file']} holds {sum(per_config)} episodes "
                        f"{per_config}, the manifest says {sum(entry['episodes_per_config'])} "
                        f"{entry['episodes_per_config']}; run `momakitchen check {root}`"
                    )
                for c in shard.config_indices():
                    for e in shard.episode_indices(c):
                        g = shard._group(f"config_{c:03d}", f"episode_{e:03d}")
                        points["global"].append(int(g["global_xyz"].shape[0]))
                        points["floor"].append(int(g["floor_xyz"].shape[0]))
                        image_shape = image_shape or list(g["rgb"].shape)
                        lab = g["floor_label"][()]
                        label_mean.append(float(lab.mean()) if lab.size else 0.0)
                        label_pos.append(float((lab > 0).mean()) if lab.size else 0.0)
            except (OSError, KeyError, ValueError) as exc:
                raise MomaError(f"shard {entry['file']}: unreadable ({exc})") from None
    n_ep = max(1, counts["total"]["episodes"])
    empty = sum(
        1
        for _, entry, _ in entries
        for c, cfg in enumerate(entry["floor_points"])
        for e, nf in enumerate(cfg)
        if nf == 0 or entry["global_points"][c][e] == 0
    )

    def rate(row: dict[str, int]) -> float | None:
        return round(row["successful_trials"] / row["trials"], 4) if row.get("trials") else None

    total = counts["total"]

    robots_in = {
        s: sorted(r for r, row in counts["robots"].items() if row[s].get("episodes"))
        for s in mf.SPLITS
    }
    return {
        "root": str(root),
        "producer": manifest["producer"],
        "generator_version": manifest["generator_version"],
        "complete": manifest["complete"],
        "incomplete": incomplete_note(manifest),
        "splits": {
            s: {**counts[s], "trial_success_rate": rate(counts[s])} for s in ("total", *mf.SPLITS)
        },
        "robots": {
            r: {s: {**row[s], "trial_success_rate": rate(row[s])} for s in row}
            for r, row in counts["robots"].items()
        },
        "targets": {
            t: {s: {**row[s], "trial_success_rate": rate(row[s])} for s in row}
            for t, row in counts["targets"].items()
        },
        "robots_in_split": robots_in,
        "bytes": total_bytes,
        "bytes_per_episode": round(total_bytes / n_ep, 1),
        "image_shape": image_shape,
        "points_per_episode": {k: _summary(v) for k, v in points.items()},
        "floor_label_mean": _summary(label_mean),
        "floor_label_positive_fraction": _summary(label_pos),
        "episodes_with_empty_cloud": empty,
        "infeasible_configurations": total.get("infeasible_configurations", 0),
        "view_coverage": (
            round(total["covering_views"] / total["feasible_views"], 4)
            if total.get("feasible_views")
            else None
        ),
    }


def _check_counts(root: Path, counts: dict[str, Any], actual: dict[str, Any]) -> None:
    """MomaError unless the manifest's ``counts`` are those its shard entries add up to
    (``actual``): a hand-edited or stale manifest is named, not reported as fact."""
    for split in ("total", *mf.SPLITS):
        for key in ("scenes", "configurations", "episodes", "trials", "successful_trials"):
            said = counts.get(split, {}).get(key)
            if said != actual[split][key]:
                raise MomaError(
                    f"{root}/manifest.json counts {said} {key} in {split!r}, its shard "
                    f"entries add up to {actual[split][key]} (edited by hand?); run "
                    f"`momakitchen check {root}`"
                )
    for table in ("robots", "targets"):
        if sorted(counts.get(table, {})) != sorted(actual[table]):
            raise MomaError(
                f"{root}/manifest.json lists {table} {sorted(counts.get(table, {}))}, its "
                f"shard entries {sorted(actual[table])}; run `momakitchen check {root}`"
            )


def _summary(values: Sequence[float]) -> dict[str, float] | None:
    if not values:
        return None
    a = np.asarray(values, np.float64)
    return {
        "mean": round(float(a.mean()), 4),
        "min": round(float(a.min()), 4),
        "max": round(float(a.max()), 4),
    }
