"""analyses/descriptor_twins.py: one arm's ground truth on another arm's views."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "descriptor_twins.py"
SCALED_YAML = Path(__file__).resolve().parents[1] / "robots" / "realman_x070.yaml"


def _scaled_realman() -> str:
    """The Realman with links x0.70, registered in this process."""
    from momakitchen.robots.spec import ROBOTS
    from momakitchen.robots.user import register_user_robot

    name = "realman_x070"
    if name not in ROBOTS:
        register_user_robot(SCALED_YAML)
    return name


def _dataset(root: Path, robot: str) -> Path:
    from momakitchen.data.config import GenerationConfig, ViewConfig
    from momakitchen.data.generator import GenerateRequest, generate_dataset
    from momakitchen.generation.producer import scene_records
    from momakitchen.scene.configuration import SceneConfig

    cfg = GenerationConfig(
        scene=SceneConfig(configs_per_scene=2, robots=(robot,)), views=ViewConfig(episodes=2)
    )
    out = root / robot
    generate_dataset(
        GenerateRequest(out=out, num_scenes=1),
        scene_records,
        cfg,
        progress=False,
        write_card=False,
    )
    return out


@pytest.fixture(scope="module")
def twins(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    # The Elephant (reach 0.63 m, 6 DoF, gripper) and the Realman scaled to 0.70 share
    # the descriptor at the Elephant's own mount.
    root = tmp_path_factory.mktemp("twins")
    return _dataset(root, "elephant"), _dataset(root, _scaled_realman())


def _run(*args: str | Path) -> subprocess.CompletedProcess:
    cmd = [sys.executable, str(SCRIPT), *map(str, args)]
    env = {**os.environ, "MOMAKITCHEN_ROBOT_YAML": str(SCALED_YAML)}
    return subprocess.run(cmd, capture_output=True, text=True, check=False, env=env)


def test_own_ground_truth_comes_back(twins, tmp_path):
    from momakitchen.data.shard import SceneShard, list_shards

    elephant, _ = twins
    out = _run(elephant, elephant, "--out", tmp_path / "self.npz")
    assert out.returncode == 0, out.stderr
    maps = np.load(tmp_path / "self.npz")
    [path] = list_shards(elephant).values()
    with SceneShard(path) as shard:
        feasible = []
        for ci in shard.config_indices():
            feasible.append(shard.configuration(ci).feasible)
            for e in shard.episode_indices(ci):
                ep = shard.episode(ci, e)
                key = f"{ep.scene_id}/{ci}/{e}"
                assert np.array_equal(maps[key], ep.floor_label.astype(np.float32))
    # An arm is its own twin: the joint ceiling is its share of feasible configurations.
    assert (
        f"joint ceiling (mean of the two Top-1 rates, grid picks): {100 * np.mean(feasible):.1f} %"
        in out.stdout
    )


def test_twin_maps_cover_every_view(twins, tmp_path):
    elephant, realman = twins
    out = _run(elephant, realman, "--out", tmp_path / "twin.npz")
    assert out.returncode == 0, out.stderr
    maps = np.load(tmp_path / "twin.npz")
    assert len(maps.files) > 0
    assert all(0.0 <= maps[k].min() and maps[k].max() <= 1.0 for k in maps.files)


def test_arms_the_descriptor_tells_apart_are_refused(twins, tmp_path):
    elephant, _ = twins
    other = _dataset(tmp_path, "flexiv")
    out = _run(elephant, other, "--out", tmp_path / "x.npz")
    assert out.returncode == 2
    assert out.stderr.strip().count("\n") == 0 and "descriptors differ" in out.stderr
    assert not (tmp_path / "x.npz").exists()


def _target_rows(stdout: str) -> list[list[str]]:
    lines = [ln for ln in stdout.splitlines() if ln.startswith("| ") and "---" not in ln]
    return [[c.strip() for c in ln.strip("|").split("|")] for ln in lines[1:]]


def _count(stages: str) -> int:
    """The total of a "stage n, stage m" cell ("–": none)."""
    return 0 if stages == "–" else sum(int(p.rsplit(" ", 1)[1]) for p in stages.split(", "))


def test_per_target_counts_add_up(twins):
    from momakitchen.data.shard import SceneShard, list_shards

    elephant, realman = twins
    own = _run(elephant, elephant)
    assert own.returncode == 0, own.stderr
    for _, _, a, b, both, fails_a, fails_b in _target_rows(own.stdout):
        assert a == b == both and fails_a == fails_b == "–"
    out = _run(elephant, realman)
    assert out.returncode == 0, out.stderr
    rows = _target_rows(out.stdout)
    totals = []
    for data in twins:
        [path] = list_shards(data).values()
        with SceneShard(path) as shard:
            totals.append(
                sum(
                    int((shard.configuration(ci).trial_stages == 0).sum())
                    for ci in shard.config_indices()
                )
            )
    assert [sum(int(r[i]) for r in rows) for i in (2, 3)] == totals
    assert sum(int(r[1]) for r in rows) == 2  # configurations
    for _, _, a, b, both, fails_a, fails_b in rows:
        # Every position one arm alone solves has a failing stage of the other.
        assert (_count(fails_a), _count(fails_b)) == (int(b) - int(both), int(a) - int(both))
