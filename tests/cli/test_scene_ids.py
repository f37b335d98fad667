"""One valid scene-id range, checked first by every command that takes ids: an id past
it is one line naming it, exit 2, before any work and with no output left behind (a huge
id used to simulate for half a minute and then fail in HDF5)."""

from __future__ import annotations

import pytest

from momakitchen.cli.main import main
from momakitchen.data.generator import GenerateRequest
from momakitchen.errors import MomaError
from momakitchen.scene.configuration import sample_scene
from momakitchen.scene.ids import MAX_SCENE_ID, MAX_SCENES, check_scene_range

HUGE = "99999999999999999999"


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["generate", "--first-scene-id", HUGE, "--scenes", "1"], HUGE),
        (["generate", "--first-scene-id", str(MAX_SCENE_ID), "--scenes", "2"], "end past"),
        (["generate", "--scenes", "100000000"], "100,000,000"),
        (["scene", "--scene-id", HUGE], HUGE),
        (["scene", "--scene-id", str(MAX_SCENE_ID + 1)], str(MAX_SCENE_ID + 1)),
        (["label", "--scene-id", HUGE, "--config", "0"], HUGE),
        (["demo", "--scene-id", HUGE], HUGE),
        (["demo", "--scene-id", "1e3"], "'1e3'"),
        (["audit", "--scenes", "0-100000000"], "100,000,001"),
        (["audit", "--scenes", "0-10000"], "[1, 10,000], got 10,001"),
        (["audit", "--scenes", f"{MAX_SCENE_ID}-{MAX_SCENE_ID + 1}"], "end past"),
    ],
)
def test_an_id_out_of_range_fails_first(argv, needle, tmp_path, capsys, monkeypatch):
    def work(*_args, **_kwargs):
        raise AssertionError("work started before the scene ids were checked")

    # The commands' work starts in one of these (each imported where the command runs).
    for name in (
        "momakitchen.scene.configuration.sample_scene",
        "momakitchen.data.generator.generate_dataset",
        "momakitchen.generation.demo.run_demo",
    ):
        monkeypatch.setattr(name, work)
    out = tmp_path / "out"
    assert main([*argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and needle in err, err
    assert str(MAX_SCENE_ID) in err or "1,000,000" in err or "10,000" in err or "1e3" in err
    assert not out.exists()


def test_the_library_checks_the_same_range(tmp_path):
    with pytest.raises(MomaError, match=r"\[0, 2147483647\], got 2147483648"):
        sample_scene(MAX_SCENE_ID + 1)
    with pytest.raises(MomaError, match="end past the last scene id"):
        GenerateRequest(out=tmp_path, num_scenes=2, first_scene_id=MAX_SCENE_ID)
    with pytest.raises(MomaError, match="number of scenes"):
        check_scene_range(0, MAX_SCENES + 1)
    check_scene_range(MAX_SCENE_ID - MAX_SCENES + 1, MAX_SCENES)


def test_the_last_id_is_a_kitchen():
    scene = sample_scene(MAX_SCENE_ID)
    assert scene.layout.scene_id == MAX_SCENE_ID
