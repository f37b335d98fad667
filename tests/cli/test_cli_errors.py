"""Bad input to the scene command: one line on stderr, exit status 2, nothing written."""

import pytest

from momakitchen.cli.main import main


@pytest.mark.parametrize("scene_id", ["-1", "abc", "1.5"])
def test_bad_scene_id(scene_id, tmp_path, capsys):
    assert main(["scene", "--scene-id", scene_id, "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and scene_id in err


def test_unwritable_out(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert main(["scene", "--scene-id", "1", "--out", str(blocker / "sub")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "sub" in err
    assert blocker.read_text() == "x"


def test_unknown_command(capsys):
    assert main(["nonsense"]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1


@pytest.mark.parametrize(
    "argv",
    [
        ["label", "--scene-id", "1", "--robot", "r2d2", "--out", "OUT"],
        ["label", "--scene-id", "1", "--config", "99", "--out", "OUT"],
    ],
)
def test_label_bad_input(argv, tmp_path, capsys):
    argv = [str(tmp_path / "o") if a == "OUT" else a for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and ("r2d2" in err or "99" in err)
    assert not (tmp_path / "o" / "labels.npz").exists()
