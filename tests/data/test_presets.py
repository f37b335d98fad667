"""Generation presets: named, frozen overrides of the defaults; ``generate --preset NAME``
with a config file's fields on top; the manifest's config names the preset."""

from __future__ import annotations

import pytest

from momakitchen import codec
from momakitchen.cli.main import main
from momakitchen.data.config import PRESETS, GenerationConfig, preset_config
from momakitchen.data.producers import config_dict
from momakitchen.errors import MomaError
from momakitchen.robots.spec import MOUNT_RANGE, get_robot_spec
from momakitchen.scene.configuration import sample_scene

# The hard preset, frozen: datasets name it in their manifests, so its values must not
# move (docs/DATASET.md, "Presets", measured them). A new set of values is a new name.
HARD = {
    "scene": {
        "obstacles": (1, 3),
        "stance_obstacles": 1,
        "stance_band": (0.5, 0.8),
        "rigid_target_prob": 0.25,
        "hard_part_weight": 3.0,
        "object_depth": 0.45,
        "robots": ("panda", "flexiv", "ur5e", "xarm6", "realman", "elephant", "ur10e", "gen3"),
        "mount_height": (0.3, 1.3),
    },
}


def _plain(mapping):
    return {k: _plain(v) if hasattr(v, "items") else v for k, v in mapping.items()}


def test_presets_are_pinned_and_frozen():
    assert list(PRESETS) == ["default", "hard"]
    assert _plain(PRESETS["default"]) == {}
    assert _plain(PRESETS["hard"]) == HARD
    with pytest.raises(TypeError):
        PRESETS["hard"]["scene"]["obstacles"] = (0, 0)  # type: ignore[index]
    with pytest.raises(TypeError):
        PRESETS["easy"] = {}  # type: ignore[index]


def test_default_preset_is_the_default_config():
    assert preset_config() == preset_config("default") == GenerationConfig()
    assert "preset" not in config_dict(preset_config("default"))  # manifests keep their bytes


def test_hard_preset_config_and_its_scenes():
    cfg = preset_config("hard")
    assert cfg.preset == "hard" and config_dict(cfg)["preset"] == "hard"
    scene = cfg.scene
    assert scene.stance_obstacles == 1 and scene.obstacles == (1, 3)
    assert scene.rigid_target_prob == 0.25 and scene.hard_part_weight == 3.0
    assert scene.object_depth == 0.45 and scene.mount_height == (0.3, 1.3)
    # Every section but scene is the default's.
    assert {k: v for k, v in config_dict(cfg).items() if k not in ("scene", "preset")} == {
        k: v for k, v in config_dict(GenerationConfig()).items() if k != "scene"
    }
    reaches = [get_robot_spec(name).reach for name in scene.robot_names]
    assert min(reaches) <= 0.65 and max(reaches) >= 1.3
    lo, hi = MOUNT_RANGE
    assert (lo, hi) == scene.mount_height
    mounts = [c.mount for c in sample_scene(800000, scene).configurations]
    assert all(lo <= m <= hi for m in mounts) and max(mounts) - min(mounts) > 0.4
    # It reads back from a manifest's config.
    assert GenerationConfig.from_dict(config_dict(cfg)) == cfg


def test_overrides_go_on_top_field_by_field():
    cfg = preset_config("hard", {"views": {"episodes": 2}, "scene": {"robots": ["ur10e"]}})
    assert cfg.views.episodes == 2 and cfg.scene.robots == ("ur10e",)
    assert cfg.scene.stance_obstacles == 1 and cfg.scene.mount_height == (0.3, 1.3)
    assert cfg.preset == "hard"
    with pytest.raises(MomaError, match="known presets: default, hard"):
        preset_config("nope")
    with pytest.raises(MomaError, match="'preset' is not a field"):
        preset_config("default", {"preset": "hard"})
    with pytest.raises(MomaError, match=r"config\.scene: stance_obstacles"):
        preset_config("hard", {"scene": {"stance_obstacles": 9}})
    with pytest.raises(MomaError, match="unknown preset 'nope'"):
        GenerationConfig(preset="nope")
    assert codec.from_dict(GenerationConfig, {"preset": "hard"}).preset == "hard"


def _capture(monkeypatch):
    seen = {}

    def fake_generate(request, scene_fn, config, progress=True):
        seen["config"] = config
        total = {"scenes": 1, "configurations": 1, "episodes": 1}
        counts = {"total": total, "train": {"episodes": 0, "scenes": 0}, "test": total}
        return {"counts": counts, "complete": True}

    monkeypatch.setattr("momakitchen.data.generator.generate_dataset", fake_generate)
    return seen


def test_generate_preset_with_a_config_file(tmp_path, monkeypatch, capsys):
    seen = _capture(monkeypatch)
    path = tmp_path / "small.yaml"
    path.write_text("views:\n  episodes: 2\nscene:\n  obstacles: [3, 4]\n")
    argv = ["generate", "--out", str(tmp_path / "d"), "--scenes", "1", "--quiet"]
    assert main([*argv, "--preset", "hard", "--config", str(path)]) == 0
    cfg = seen["config"]
    assert cfg.preset == "hard" and config_dict(cfg)["preset"] == "hard"
    assert cfg.views.episodes == 2 and cfg.scene.obstacles == (3, 4)
    assert cfg.scene.stance_obstacles == 1
    assert main([*argv, "--config", str(path)]) == 0
    assert seen["config"].preset == "" and seen["config"].scene.stance_obstacles == 0
    assert main(argv) == 0 and seen["config"] == GenerationConfig()


@pytest.mark.parametrize(
    ("extra", "needle"),
    [
        (["--preset", "nope"], "unknown preset 'nope'; known presets: default, hard"),
        (["--preset", "hard", "--synthetic"], "--preset"),
    ],
)
def test_generate_bad_preset_is_one_line(tmp_path, monkeypatch, capsys, extra, needle):
    seen = _capture(monkeypatch)
    out = tmp_path / "d"
    assert main(["generate", "--out", str(out), "--scenes", "1", *extra]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and needle in err, err
    assert not seen and not out.exists()


def test_a_preset_key_in_the_file_is_refused(tmp_path, monkeypatch, capsys):
    _capture(monkeypatch)
    path = tmp_path / "p.yaml"
    path.write_text("preset: hard\n")
    assert main(["generate", "--out", str(tmp_path / "d"), "--scenes", "1", "--config", str(path)])
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "p.yaml" in err and "--preset" in err, err
