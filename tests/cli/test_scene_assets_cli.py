"""`momakitchen scene --assets DIR` with a broken external asset folder."""

from momakitchen.cli.main import main


def test_broken_external_urdf_is_a_one_line_error(tmp_path, capsys):
    folder = tmp_path / "assets" / "Bottle" / "101"
    folder.mkdir(parents=True)
    (folder / "mobility.urdf").write_text("<robot name='b'><link name='base'>")  # truncated
    out = tmp_path / "out"
    assert (
        main(["scene", "--scene-id", "3", "--out", str(out), "--assets", str(tmp_path / "assets")])
        == 2
    )
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "mobility.urdf" in err
    assert not (out / "scene.json").exists()
