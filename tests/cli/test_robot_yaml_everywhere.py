"""``--robot-yaml`` on every command that takes a robot or builds worlds: the option is
known, and the file is registered (a missing one is named) before the command's own work."""

from __future__ import annotations

import pytest

from momakitchen.cli.main import main

COMMANDS = [
    ["scene", "--scene-id", "1", "--out", "OUT"],
    ["generate", "--out", "OUT", "--scenes", "1"],
    ["msr", "--data", "NODATA", "--method", "oracle", "--json", "OUT/m.json"],
    ["robustness", "--data", "NODATA", "--json", "OUT/r.json", "--out", "OUT"],
    ["audit", "--data", "NODATA", "--out", "OUT"],
    ["export-inputs", "--data", "NODATA", "--out", "OUT/x.h5"],
    ["approach", "--data", "NODATA", "--json", "OUT/a.json"],
    ["benchmark", "--data", "NODATA", "--out", "OUT"],
    ["train", "--data", "NODATA", "--model", "navaff", "--out", "OUT"],
    ["evaluate", "--data", "NODATA", "--json", "OUT/e.json"],
]


@pytest.mark.parametrize("argv", COMMANDS, ids=[a[0] for a in COMMANDS])
def test_robot_yaml_is_an_option_and_is_read_first(argv, tmp_path, capsys):
    repl = {"OUT": str(tmp_path / "out"), "NODATA": str(tmp_path / "nodata")}
    argv = [repl.get(a, a.replace("OUT", str(tmp_path / "out"))) for a in argv]
    missing = tmp_path / "absent.yaml"
    assert main([*argv, "--robot-yaml", str(missing)]) == 2
    err = capsys.readouterr().err
    assert "unrecognized arguments" not in err, err
    assert err.count("\n") == 1 and "absent.yaml" in err and "does not exist" in err
    assert not (tmp_path / "out").exists()
