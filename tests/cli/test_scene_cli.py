import json

from momakitchen.cli.main import main


def test_scene_command_is_deterministic(tmp_path, capsys):
    a, b = tmp_path / "a", tmp_path / "b"
    assert main(["scene", "--scene-id", "7", "--out", str(a)]) == 0
    assert main(["scene", "--scene-id", "7", "--out", str(b), "--no-render"]) == 0
    assert (a / "scene.json").read_bytes() == (b / "scene.json").read_bytes()
    png = (a / "overview.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 50_000
    data = json.loads((a / "scene.json").read_text())
    assert data["layout"]["scene_id"] == 7 and len(data["configurations"]) == 10
    assert "scene 7" in capsys.readouterr().out
    assert not list(a.glob(".*tmp*")), "no temporary files left behind"


def test_scene_config_out_of_range(tmp_path, capsys):
    assert (
        main(
            ["scene", "--scene-id", "1", "--out", str(tmp_path), "--configs", "2", "--config", "5"]
        )
        == 2
    )
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "5" in err
