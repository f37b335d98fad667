"""Reading a simulator-made dataset for evaluation: its generation config, the
configurations of a split, their worlds rebuilt scene by scene, and the view of each that
the tracks judge (``msr``, ``robustness`` and the approach track's near start share it)."""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from momakitchen.data import manifest as mf
from momakitchen.data.shard import SceneShard
from momakitchen.errors import MomaError


def dataset_generation(root: Path) -> tuple[dict[str, Any], Any]:
    """The manifest of a simulator-made dataset and its generation config (what rebuilds
    its worlds); MomaError otherwise, one line naming the files to register where the
    dataset was labelled with a user robot that is not registered here."""
    from momakitchen.data.config import GenerationConfig

    manifest = _load_sim_dataset(root)
    mf.check_user_robots(manifest, root)
    try:
        return manifest, GenerationConfig.from_dict(manifest["config"])
    except (TypeError, KeyError, ValueError) as exc:
        raise MomaError(f"{root}: unreadable generation config in manifest.json ({exc})") from exc


def _load_sim_dataset(root: Path) -> dict[str, Any]:
    manifest = mf.load_manifest(root)
    if manifest.get("producer") != mf.KITCHEN or "config" not in manifest:
        raise MomaError(
            f"{root} was not made by the simulator-backed generator (producer "
            f"{manifest.get('producer')!r}): MSR needs the generation config to "
            "rebuild its worlds"
        )
    return manifest


def split_configurations(manifest: dict[str, Any], split: str) -> list[tuple[int, int, str]]:
    """(scene_id, config_index, shard file) of every configuration of a split (``"all"``:
    both) of a dataset's manifest, in scene order."""
    todo = []
    for key in sorted(manifest["shards"], key=int):
        entry = manifest["shards"][key]
        if split == "all" or entry["split"] == split:
            todo += [(int(key), c, entry["file"]) for c in range(len(entry["episodes_per_config"]))]
    return todo


def judged_configurations(
    root: Path, manifest: dict[str, Any], split: str, max_configs: int
) -> list[tuple[int, int, str]]:
    """:func:`split_configurations`, the first ``max_configs`` (0: all); MomaError when
    there is none."""
    todo = split_configurations(manifest, split)
    if max_configs:
        todo = todo[:max_configs]
    if not todo:
        raise MomaError(f"dataset {str(root)!r} has no {split} configurations")
    return todo


def rebuilt_configurations(
    root: Path, todo: Iterable[tuple[int, int, str]], scene_config: Any
) -> Iterator[tuple[Any, SceneShard, int]]:
    """(scene, its shard, config_index) for each item of ``todo`` (as
    :func:`split_configurations` gives, grouped by scene): each scene is rebuilt and its
    shard under ``root`` opened once, and closed when the next scene starts or at the end."""
    from momakitchen.scene.configuration import sample_scene

    scene, shard = None, None
    try:
        for sid, ci, file in todo:
            if scene is None or scene.layout.scene_id != sid:
                scene = sample_scene(sid, scene_config)
                if shard is not None:
                    shard.close()
                shard = SceneShard(root / file)
            assert shard is not None  # opened with the scene above
            yield scene, shard, ci
    finally:
        if shard is not None:
            shard.close()


def judged_view(shard: SceneShard, scene: Any, ci: int, seed: int) -> int | None:
    """The episode (view) of configuration ``ci`` that MSR judges for ``seed`` (None when
    the configuration has no view with floor points, or the rebuilt scene lacks it)."""
    episodes = [e for e in shard.episode_indices(ci) if shard.num_points(ci, e)[1] > 0]
    if ci >= len(scene.configurations) or not episodes:
        return None
    stored = shard.configuration(ci)
    rebuilt = scene.configurations[ci]
    if (rebuilt.robot, rebuilt.mount_height) != (stored.robot, stored.mount_height):
        raise MomaError(
            f"{shard.path.name} configuration {ci}: stored robot "
            f"{_robot_at(stored.robot, stored.mount_height)} but the rebuilt world has "
            f"{_robot_at(rebuilt.robot, rebuilt.mount_height)} (another momakitchen version?)"
        )
    rng = np.random.default_rng([seed, scene.layout.scene_id, ci])
    return int(episodes[int(rng.integers(len(episodes)))])


def _robot_at(robot: str, mount: float | None) -> str:
    return repr(robot) + ("" if mount is None else f" at mount height {mount} m")


def view_record(
    scene_id: int, config_index: int, episode_index: int, labels: Any, **more: Any
) -> dict[str, Any]:
    """The head of a judged view's record (MSR, the robustness track), then ``more``."""
    return {
        "scene_id": scene_id,
        "config_index": config_index,
        "episode_index": episode_index,
        "robot": labels.robot,
        "target": labels.target,
        "feasible": bool(labels.trial_outcomes.any()),
        **more,
    }
