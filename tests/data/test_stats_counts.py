"""`stats` and `check` do not believe a hand-edited manifest: its counts must be those its
shard entries add up to, and each shard must hold the episodes its entry lists."""

from __future__ import annotations

import json
import shutil

import pytest
from dataset_helpers import make_dataset

from momakitchen.cli.main import main


@pytest.fixture(scope="module")
def sound(tmp_path_factory):
    root = tmp_path_factory.mktemp("stats") / "ds"
    make_dataset(root, scenes=5)
    return root


def _edited(sound, tmp_path, edit):
    root = tmp_path / "ds"
    shutil.copytree(sound, root)
    path = root / "manifest.json"
    manifest = json.loads(path.read_text())
    edit(manifest)
    path.write_text(json.dumps(manifest))
    return root


def _total_500(m):
    m["counts"]["total"]["episodes"] = 500


def _train_edited(m):
    m["counts"]["train"]["episodes"] += 1


def _entry_edited(m):  # an entry and the counts edited together: only the shard disagrees
    entry = m["shards"]["1"]
    entry["episodes_per_config"][0] += 1
    for key in ("total", entry["split"]):
        m["counts"][key]["episodes"] += 1
    robot, target = entry["robots"][0], entry["targets"][0].split("/")[0]
    for table, name in (("robots", robot), ("targets", target)):
        for key in ("total", entry["split"]):
            m["counts"][table][name][key]["episodes"] += 1


@pytest.mark.parametrize(
    ("edit", "needle"),
    [
        (_total_500, "counts 500 episodes in 'total', its shard entries add up to 30"),
        (_train_edited, "episodes in 'train'"),
        (_entry_edited, "scene_000001.h5 holds 6 episodes"),
    ],
)
def test_stats_refuses_counts_the_shards_do_not_hold(sound, tmp_path, capsys, edit, needle):
    root = _edited(sound, tmp_path, edit)
    assert main(["stats", str(root)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and needle in err, err
    assert main(["check", str(root), "--quiet"]) == 2


def test_stats_prints_no_python_dicts(sound, capsys):
    assert main(["stats", str(sound)]) == 0
    out = capsys.readouterr().out
    assert "{" not in out and "[" not in out, out
    assert "points per episode: global mean" in out
