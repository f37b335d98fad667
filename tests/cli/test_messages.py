"""One wording per rule; a failed run creates no --out directory; --robot-yaml wherever a
command takes --robot."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from momakitchen.cli.main import main


def _error(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    return err


@pytest.mark.parametrize("value", ["0", "-1", "x"])
def test_scenes_states_its_rule_once(value, tmp_path, capsys):
    """`--scenes` does not call itself non-negative and then refuse 0."""
    assert main(["generate", "--synthetic", "--out", str(tmp_path / "d"), "--scenes", value]) == 2
    err = _error(capsys)
    assert f"--scenes: expected an integer >= 1, got '{value}'" in err
    assert "non-negative" not in err
    assert not (tmp_path / "d").exists()


@pytest.mark.parametrize("value", ["0", "-2", "nan"])
def test_target_mass_states_its_rule_once(value, tmp_path, capsys):
    """`--target-mass` refuses 0 at once, saying > 0 (not ">= 0" and then refusing 0)."""
    argv = ["label", "--scene-id", "1", "--out", str(tmp_path / "o"), "--target-mass", value]
    assert main(argv) == 2
    err = _error(capsys)
    assert f"--target-mass: expected a finite number > 0, got '{value}'" in err
    assert ">= 0" not in err
    assert not (tmp_path / "o").exists()


def test_config_index_has_one_wording(tmp_path, capsys):
    """scene, label and demo word an out-of-range --config alike (no "< 10" beside
    "[0, 9]"), and none of them leaves its --out behind."""
    errors = []
    for argv in (
        ["scene", "--scene-id", "1", "--no-render"],
        ["label", "--scene-id", "1", "--quiet"],
        ["demo"],
    ):
        out = tmp_path / argv[0]
        assert main([*argv, "--config", "12", "--out", str(out)]) == 2
        errors.append(_error(capsys).split("error: ", 1)[1])
        assert not out.exists()
    assert errors == ["--config must be in [0, 9], got 12"] * 3


@pytest.mark.parametrize(
    "argv",
    [
        ["stats", "FILE"],
        ["check", "FILE"],
        ["train", "--data", "FILE", "--model", "navaff", "--out", "RUN"],
        ["evaluate", "--data", "FILE", "--checkpoint", "FILE", "--json", "J"],
        ["msr", "--data", "FILE", "--json", "J"],
    ],
)
def test_a_file_given_for_a_directory_is_called_a_file(argv, tmp_path, capsys):
    """A regular file where a directory belongs: "is not a directory", never "does not
    exist"."""
    f = tmp_path / "notes.txt"
    f.write_text("x")
    repl = {"FILE": str(f), "RUN": str(tmp_path / "run"), "J": str(tmp_path / "m.json")}
    assert main([repl.get(a, a) for a in argv]) == 2
    err = _error(capsys)
    assert f"{str(f)!r} is not a directory" in err and "does not exist" not in err
    assert f.read_text() == "x" and not (tmp_path / "run").exists()


def test_failed_predict_creates_no_output_directory(tmp_path, capsys):
    """An all-zero depth image: one line, exit 2, and no empty --out."""
    depth, mask, tf = tmp_path / "d.npy", tmp_path / "m.npy", tmp_path / "tf.txt"
    np.save(depth, np.zeros((24, 32), np.float32))
    target = np.zeros((24, 32), bool)
    target[5:9, 10:14] = True
    np.save(mask, target)
    np.savetxt(tf, np.eye(4))
    out = tmp_path / "pred"
    argv = ["predict", "--depth", str(depth), "--intrinsics", "30", "30", "16", "12"]
    argv += ["--extrinsics", str(tf), "--target-mask", str(mask), "--robot", "panda"]
    assert main([*argv, "--out", str(out)]) == 2
    assert "no valid pixel" in _error(capsys)
    assert not out.exists()


@pytest.mark.parametrize(
    "argv",
    [
        ["label", "--scene-id", "1", "--robot", "NAME", "--config", "12", "--out", "OUT"],
        ["demo", "--robot", "NAME", "--config", "12", "--out", "OUT"],
        ["predict", "--depth", "MISSING.npy", "--intrinsics", "1", "1", "1", "1"],
    ],
)
def test_robot_yaml_on_every_command_that_takes_a_robot(argv, tmp_path, capsys):
    """--robot-yaml registers the user robot before the command runs: --robot then knows
    it (the command goes on to its next check), and a bad YAML is named."""
    import sys

    sys.path.insert(0, str(Path(__file__).parent))
    try:
        from test_robots_cli import kuka_yaml
    finally:
        sys.path.pop(0)
    from momakitchen.robots.spec import ROBOTS
    from momakitchen.robots.user import unregister_user_robot

    name = f"kuka_{argv[0]}"
    good = kuka_yaml(tmp_path, name, reach=0.8)
    repl = {"NAME": name, "OUT": str(tmp_path / "out"), "MISSING.npy": str(tmp_path / "no.npy")}
    argv = [repl.get(a, a) for a in argv]
    if argv[0] == "predict":
        argv += ["--extrinsics", "e.txt", "--target-mask", "m.npy", "--robot", name]
        argv += ["--out", str(tmp_path / "out")]
    try:
        assert main([*argv, "--robot-yaml", str(good)]) == 2
        err = _error(capsys)
        assert "unrecognized arguments" not in err and "unknown robot" not in err, err
        assert "--config must be in [0, 9], got 12" in err or "no.npy" in err
        assert not (tmp_path / "out").exists()
        assert main([*argv, "--robot-yaml", str(tmp_path / "absent.yaml")]) == 2
        assert "absent.yaml" in _error(capsys)
    finally:
        if name in ROBOTS:
            unregister_user_robot(name)


@pytest.mark.parametrize(
    "argv",
    [
        ["train", "--data", "D", "--model", "navaff", "--out", "RUN", "--config", "DIR.yaml"],
        ["generate", "--out", "RUN", "--scenes", "1", "--config", "DIR.yaml"],
        ["predict", "--depth", "DIR.yaml", "--intrinsics", "1", "1", "1", "1", "--robot", "panda"],
    ],
)
def test_a_directory_given_for_a_file_is_called_a_directory(argv, tmp_path, capsys):
    """A directory where a file belongs: "is not a file", never "does not exist"."""
    d = tmp_path / "DIR.yaml"
    d.mkdir()
    repl = {"DIR.yaml": str(d), "D": str(tmp_path), "RUN": str(tmp_path / "run")}
    argv = [repl.get(a, a) for a in argv]
    if argv[0] == "predict":
        argv += ["--extrinsics", "e", "--target-mask", "m", "--out", str(tmp_path / "run")]
    assert main(argv) == 2
    err = _error(capsys)
    assert f"{str(d)!r} is not a file" in err and "does not exist" not in err
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize("command", ["scene", "import-reference"])
def test_a_file_given_for_a_folder_is_called_a_file(command, tmp_path, capsys):
    f = tmp_path / "notes.txt"
    f.write_text("x")
    if command == "scene":
        argv = ["scene", "--scene-id", "1", "--no-render", "--assets", str(f)]
    else:
        argv = ["import-reference", str(f)]
    assert main([*argv, "--out", str(tmp_path / "out")]) == 2
    err = _error(capsys)
    assert f"{str(f)!r} is not a directory" in err and not (tmp_path / "out").exists()


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs /proc")
def test_an_out_that_cannot_be_made_fails_before_the_work(capsys, monkeypatch):
    """Root may write everywhere by permissions, yet nothing can be made under /proc: the
    label command must say so before its trials, not after."""
    import momakitchen.sim.labels as labels

    def no_trials(*_args, **_kwargs):
        raise AssertionError("trials ran before --out was checked")

    monkeypatch.setattr(labels, "label_configuration", no_trials)
    assert main(["label", "--scene-id", "1", "--out", "/proc/momakitchen-out", "--quiet"]) == 2
    assert "cannot write to output directory '/proc/momakitchen-out'" in _error(capsys)


def test_predict_names_the_bad_reach(tmp_path, capsys):
    depth, mask, tf = tmp_path / "d.npy", tmp_path / "m.npy", tmp_path / "tf.txt"
    np.save(depth, np.ones((24, 32), np.float32))
    target = np.zeros((24, 32), bool)
    target[5:9, 10:14] = True
    np.save(mask, target)
    np.savetxt(tf, np.eye(4))
    argv = ["predict", "--depth", str(depth), "--intrinsics", "30", "30", "16", "12"]
    argv += ["--extrinsics", str(tf), "--target-mask", str(mask), "--out", str(tmp_path / "o")]
    assert main([*argv, "--reach", "-1", "--mount-height", "1"]) == 2
    assert "robot reach must be in [0.2, 3] m, got -1.0" in _error(capsys)
    assert main([*argv, "--reach", "0.8", "--mount-height", "1", "--finger-force", "500"]) == 2
    assert "robot finger_force must be in [10, 200] N, got 500.0" in _error(capsys)
