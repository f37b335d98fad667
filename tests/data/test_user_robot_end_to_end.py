"""Slow end-to-end run of the simulator-backed producer with a user robot: the Panda from
its URDF on a mount drawn from [0.6, 1.3] m, made with one worker and with two (the same
bytes), then read by msr (which says which file to pass until it is registered) and by
evaluate (which reads the stored descriptors and needs no robot)."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest
from dataset_helpers import write_panda_yaml

from momakitchen.cli.main import main
from momakitchen.data.shard import SceneShard, list_shards
from momakitchen.robots.spec import ROBOTS
from momakitchen.robots.user import ENV_VAR, unregister_user_robot

pytestmark = pytest.mark.slow

# Two scenes, one configuration each, two views, a coarse trial grid: about a minute.
SMALL = "scene:\n  configs_per_scene: 1\n  grid_spacing: 0.2\nviews:\n  episodes: 2\n"


def _digests(root: Path) -> dict[str, str]:
    files = [*sorted((root / "scenes").iterdir()), root / "manifest.json"]
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in files}


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    """``(dataset made with 2 workers, with 1, the robot YAML)``."""
    tmp = tmp_path_factory.mktemp("user_e2e")
    yaml_path = write_panda_yaml(tmp, "pandarange", "[0.6, 1.3]")
    config = tmp / "small.yaml"
    config.write_text(SMALL)
    common = ["--scenes", "2", "--config", str(config), "--robot", "pandarange", "--quiet"]
    two, one = tmp / "two", tmp / "one"
    try:
        argv = ["generate", "--out", str(two), "--workers", "2", *common]
        assert main([*argv, "--robot-yaml", str(yaml_path)]) == 0
        unregister_user_robot("pandarange")  # the second run registers it from the variable
        mp = pytest.MonkeyPatch()
        mp.setenv(ENV_VAR, str(yaml_path))
        try:
            assert main(["generate", "--out", str(one), "--workers", "1", *common]) == 0
        finally:
            mp.undo()
    finally:
        if "pandarange" in ROBOTS:
            unregister_user_robot("pandarange")
    return two, one, yaml_path


def test_same_bytes_for_any_worker_count(made):
    two, one, yaml_path = made
    assert _digests(two) == _digests(one)
    manifest = json.loads((two / "manifest.json").read_text())
    (record,) = manifest["user_robots"]
    assert record["name"] == "pandarange" and record["yaml"] == str(yaml_path.resolve())
    assert manifest["config"]["scene"]["robots"] == ["pandarange"]
    assert "pandarange" in (two / "README.md").read_text()


def test_the_drawn_mount_height_is_recorded_and_carries_the_camera(made):
    two, _, _ = made
    heights = []
    for path in list_shards(two).values():
        with SceneShard(path) as shard:
            labels = shard.configuration(0)
            assert labels.robot == "pandarange" and labels.mount_height is not None
            assert 0.6 <= labels.mount_height <= 1.3
            heights.append(labels.mount_height)
            for e in shard.episode_indices(0):
                episode = shard.episode(0, e)
                assert episode.descriptor[1] == pytest.approx(labels.mount_height)
                assert episode.descriptor[0] == pytest.approx(0.85)
                # The head camera stands 0.3 m above the arm's mount.
                camera_z = float(episode.camera_pose[2, 3])
                assert camera_z == pytest.approx(labels.mount_height + 0.3, abs=1e-6)
    assert len(set(heights)) == 2


def test_msr_names_the_file_then_runs_with_it(made, tmp_path, capsys):
    two, _, yaml_path = made
    out = tmp_path / "msr.json"
    argv = ["msr", "--data", str(two), "--method", "oracle", "--json", str(out), "--quiet"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and not out.exists()
    assert f"was labelled with user robot 'pandarange' (from {yaml_path.resolve()})" in err
    assert f"pass --robot-yaml {yaml_path.resolve()}" in err
    try:
        assert main([*argv, "--robot-yaml", str(yaml_path), "--split", "all"]) == 0
    finally:
        unregister_user_robot("pandarange")
    result = json.loads(out.read_text())
    assert {r["robot"] for r in result["records"]} == {"pandarange"}
    assert "oracle" in result["records"][0]["methods"]


def test_evaluate_reads_the_stored_descriptors_without_the_robot(made, tiny_run, tmp_path):
    two, _, _ = made
    out = tmp_path / "eval.json"
    argv = ["evaluate", "--checkpoint", str(tiny_run), "--data", str(two), "--split", "all"]
    assert main([*argv, "--json", str(out)]) == 0
    result = json.loads(out.read_text())
    assert set(result["per_robot"]) == {"pandarange"}
    assert np.isfinite(result["metrics"]["pcc"])
