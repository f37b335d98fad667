"""User robots in generation: the workers of both backends register the driver's user robots
(checking their content hash), the manifest records the files the data was labelled with,
readers say which files to register, and bad input is one line before anything is written."""

from __future__ import annotations

import hashlib
import json
import multiprocessing
from pathlib import Path

import pytest
from dataset_helpers import RobotRecordsConfig, robot_records, write_panda_yaml

from momakitchen.cli.main import main
from momakitchen.data import manifest as mf
from momakitchen.data.generator import GenerateRequest, _scene_bytes_task, generate_dataset
from momakitchen.data.shard import file_summary, list_shards
from momakitchen.errors import MomaError
from momakitchen.robots.spec import ROBOTS
from momakitchen.robots.user import (
    register_user_robot,
    unregister_user_robot,
    user_robot_file,
    user_robot_files,
)
from momakitchen.scene.configuration import SceneConfig


@pytest.fixture
def user_robots():
    """``register(path) -> spec``; every robot registered through it is removed after."""
    names: list[str] = []

    def register(path: Path):
        spec = register_user_robot(path)
        names.append(spec.name)
        return spec

    yield register
    for name in names:
        if name in ROBOTS:
            unregister_user_robot(name)


def _digests(root: Path) -> dict[str, str]:
    files = [*sorted((root / "scenes").iterdir()), root / "manifest.json"]
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in files}


def _generate(root: Path, config: RobotRecordsConfig, workers: int = 1) -> dict:
    request = GenerateRequest(out=root, num_scenes=2, workers=workers)
    return generate_dataset(request, robot_records, config, progress=False, write_card=False)


def test_pool_workers_register_the_drivers_user_robots(tmp_path, user_robots):
    yaml_path = write_panda_yaml(tmp_path)
    spec = user_robots(yaml_path)
    user_robots(write_panda_yaml(tmp_path, "pandahigh", 1.3))  # registered, not used
    config = RobotRecordsConfig(scene=SceneConfig(robots=("pandalow", "panda")))
    one = _generate(tmp_path / "one", config)
    two = _generate(tmp_path / "two", config, workers=2)  # spawned: they start bare
    assert _digests(tmp_path / "one") == _digests(tmp_path / "two")
    assert {"pandalow", "panda"} == set(one["counts"]["robots"])
    # The manifest names the user robots the data was labelled with, by content hash.
    files = user_robot_file("pandalow")
    assert files is not None and files.yaml == str(yaml_path.resolve())
    assert one["user_robots"] == two["user_robots"] == [files.to_dict()]
    assert len(files.sha256) == 64 and spec.mount_height == 0.6
    assert mf.manifest_user_robots(mf.load_manifest(tmp_path / "two")) == [files.to_dict()]


def test_a_ray_task_registers_them_itself(tmp_path, user_robots):
    user_robots(write_panda_yaml(tmp_path))
    config = RobotRecordsConfig(scene=SceneConfig(robots=("pandalow",)))
    _generate(tmp_path / "local", config)
    records = tuple(f.to_dict() for f in user_robot_files(["pandalow"]))
    # A bare process (no pool initializer), as a Ray worker is.
    with multiprocessing.get_context("spawn").Pool(1) as pool:
        with pytest.raises(MomaError, match="unknown robot 'pandalow'"):
            pool.apply(_scene_bytes_task, (robot_records, config, 1, ()))
        summary, data = pool.apply(_scene_bytes_task, (robot_records, config, 1, records))
    assert data == list_shards(tmp_path / "local")[1].read_bytes()
    assert summary == file_summary(1, robot_records(1, config), data)


def test_a_worker_finding_other_contents_stops_the_run_naming_the_file(tmp_path, user_robots):
    yaml_path = write_panda_yaml(tmp_path)
    user_robots(yaml_path)
    yaml_path.write_text(yaml_path.read_text() + "# edited after the driver read it\n")
    config = RobotRecordsConfig(scene=SceneConfig(robots=("pandalow",)))
    with pytest.raises(MomaError, match=r"registered from .*pandalow.yaml with sha256") as info:
        _generate(tmp_path / "ds", config, workers=2)
    assert "\n" not in str(info.value) and "YAML or URDF changed" in str(info.value)


def test_resuming_with_other_user_robot_files_is_refused(tmp_path, user_robots):
    user_robots(write_panda_yaml(tmp_path))
    config = RobotRecordsConfig(scene=SceneConfig(robots=("pandalow",)))
    _generate(tmp_path / "ds", config)
    unregister_user_robot("pandalow")
    other = tmp_path / "other"
    other.mkdir()
    user_robots(write_panda_yaml(other, mount_height=0.7))
    with pytest.raises(MomaError, match=r"other user robot files .*robot 'pandalow'"):
        _generate(tmp_path / "ds", config)


def test_readers_name_the_files_to_register(tmp_path, user_robots):
    yaml_path = write_panda_yaml(tmp_path)
    user_robots(yaml_path)
    root = tmp_path / "ds"
    _generate(root, RobotRecordsConfig(scene=SceneConfig(robots=("pandalow",))))
    manifest = mf.load_manifest(root)
    mf.check_user_robots(manifest, root)  # registered: fine
    unregister_user_robot("pandalow")
    with pytest.raises(MomaError) as info:
        mf.check_user_robots(manifest, root)
    assert str(info.value) == (
        f"dataset {str(root)!r} was labelled with user robot 'pandalow' (from "
        f"{yaml_path.resolve()}); pass --robot-yaml {yaml_path.resolve()} (or set "
        "MOMAKITCHEN_ROBOT_YAML)"
    )
    changed = tmp_path / "changed"
    changed.mkdir()
    user_robots(write_panda_yaml(changed, mount_height=0.9))
    with pytest.raises(MomaError, match=r"sha256 .* but 'pandalow' is registered from .*changed"):
        mf.check_user_robots(manifest, root)


def _error(capsys) -> str:
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    return err


@pytest.mark.parametrize(
    ("extra", "config", "message"),
    [
        (["--robot", "nope"], "", "unknown robot 'nope'"),
        (["--robot", "panda", "--synthetic"], "", "--robot sets the simulator's robots"),
        (
            [],
            "scene:\n  mount_height: 1.5\n",
            "scene.mount_height must be in [0.3, 1.3] m, got 1.5",
        ),
        ([], "scene:\n  mount_height: [0.5, 2]\n", "got 2.0 (in the range [0.5, 2.0])"),
    ],
)
def test_bad_generate_input_is_one_line_and_writes_nothing(
    tmp_path, capsys, extra, config, message
):
    out = tmp_path / "ds"
    argv = ["generate", "--out", str(out), "--scenes", "1", "--quiet", *extra]
    if config:
        (tmp_path / "gen.yaml").write_text(config)
        argv += ["--config", str(tmp_path / "gen.yaml")]
    assert main(argv) == 2
    assert message in _error(capsys)
    assert not out.exists()


def test_bad_user_robots_are_one_line_and_write_nothing(tmp_path, capsys):
    out = tmp_path / "ds"
    base = ["generate", "--out", str(out), "--scenes", "1", "--quiet"]
    missing_link = write_panda_yaml(tmp_path, "nolink")
    missing_link.write_text(missing_link.read_text().replace("panda_grasptarget", "tool9"))
    assert main([*base, "--robot-yaml", str(missing_link)]) == 2
    assert "no link 'tool9' (end_effector_link in" in _error(capsys)
    high = write_panda_yaml(tmp_path, "toohigh", "[0.6, 1.4]")
    assert main([*base, "--robot-yaml", str(high)]) == 2
    assert "toohigh.yaml: field 'mount_height': mount_height must be in" in _error(capsys)
    stubby = write_panda_yaml(tmp_path, "stubby", 0.3)
    stubby.write_text(stubby.read_text().replace("reach: 0.85", "reach: 0.2"))
    try:
        assert main([*base, "--robot-yaml", str(stubby), "--robot", "stubby"]) == 2
        err = _error(capsys)
        assert "robot 'stubby' (user robot " in err and "cannot reach the counter" in err
        assert "stubby.yaml" in err
    finally:
        unregister_user_robot("stubby")
    assert not out.exists()
    for name in ("nolink", "toohigh"):
        assert name not in ROBOTS


def test_the_manifest_and_card_of_built_in_robots_hold_no_user_robots(small_dataset):
    manifest = json.loads((small_dataset / "manifest.json").read_text())
    assert "user_robots" not in manifest and '"mount_height"' not in json.dumps(manifest)
    assert "User robots" not in (small_dataset / "README.md").read_text()
