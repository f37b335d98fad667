"""An unfinished generation is not OK for `check` (exit 2 with the number of scenes
missing) unless --allow-incomplete; `stats` says how unfinished it is."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from dataset_helpers import SMALL

from momakitchen.cli.main import main
from momakitchen.data.generator import GenerateRequest, generate_dataset
from momakitchen.data.synthetic_scene import synthetic_scene_records


def _interrupted_at(scene_id: int):
    """A producer that is interrupted (Ctrl-C) when it reaches ``scene_id``."""

    def scene_fn(sid, config):
        if sid == scene_id:
            raise KeyboardInterrupt
        return synthetic_scene_records(sid, config)

    return scene_fn


def _interrupted_dataset(root: Path, scenes: int, at: int) -> None:
    with pytest.raises(KeyboardInterrupt):
        generate_dataset(
            GenerateRequest(out=root, num_scenes=scenes),
            _interrupted_at(at),
            SMALL,
            progress=False,
            write_card=False,
        )


@pytest.mark.parametrize(("scenes", "at", "missing"), [(1, 0, 1), (3, 2, 1), (4, 1, 3)])
def test_check_refuses_an_unfinished_dataset(tmp_path, capsys, scenes, at, missing):
    root = tmp_path / "ds"
    _interrupted_dataset(root, scenes, at)
    assert json.loads((root / "manifest.json").read_text())["complete"] is False
    assert main(["check", str(root), "--quiet"]) == 2
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert len(err.splitlines()) == 1 and "OK" not in captured.out
    assert f"generation incomplete: {missing} of {scenes} requested scenes missing" in err
    assert "--allow-incomplete" in err
    assert main(["check", str(root), "--quiet", "--allow-incomplete"]) == 0
    out = capsys.readouterr().out
    shards = f"{at} shard" if at == 1 else f"{at} shards"  # counts are pluralised
    assert f"OK: {shards}," in out and f"{missing} of {scenes} requested scenes missing" in out
    assert main(["stats", str(root)]) == 0
    assert f"{missing} of {scenes} requested scenes missing" in capsys.readouterr().out


def test_check_passes_once_the_run_is_finished(tmp_path, capsys):
    root = tmp_path / "ds"
    _interrupted_dataset(root, 3, 2)
    generate_dataset(
        GenerateRequest(out=root, num_scenes=3),
        _interrupted_at(-1),  # the same producer name, no interruption this time
        SMALL,
        progress=False,
        write_card=False,
    )
    assert main(["check", str(root), "--quiet"]) == 0
    assert "incomplete" not in capsys.readouterr().out
