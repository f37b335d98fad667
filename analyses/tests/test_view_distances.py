"""analyses/view_distances.py: each view's distance from its target, and the far share."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np

from momakitchen.data.manifest import load_manifest
from momakitchen.data.shard import SceneShard

SCRIPT = Path(__file__).resolve().parents[1] / "view_distances.py"


def each_view(root):
    """(shard, config_index, episode_index) of every view of the dataset, in its order."""
    for entry in load_manifest(root)["shards"].values():
        with SceneShard(root / entry["file"]) as shard:
            for ci in shard.config_indices():
                for e in shard.episode_indices(ci):
                    yield shard, ci, e


def test_distances_are_each_views_from_its_anchor(real_dataset, monkeypatch):
    monkeypatch.syspath_prepend(str(SCRIPT.parent))
    from view_distances import format_distances, view_distances

    expected = []
    for shard, ci, e in each_view(real_dataset):
        anchor = np.asarray(shard.configuration(ci).anchor)[:2]
        base = shard.episode(ci, e).base_pose
        expected.append(np.hypot(base[0] - anchor[0], base[1] - anchor[1]))
    dist, room = view_distances(real_dataset, 3.8, 6.0, 45.0)
    assert np.allclose(dist, expected) and len(room) == len(dist)
    # a "far" from below every view counts them all; one past the room's depth, no room
    assert "100.0% of all views" in format_distances(dist, room, float(dist.min()))
    _, none = view_distances(real_dataset, 9.0, 10.0, 45.0)
    assert not none.any()
    assert "nan% of the 0 views" in format_distances(dist, none, 9.0)


def test_a_missing_dataset_is_one_line(tmp_path):
    proc = subprocess.run(
        [sys.executable, str(SCRIPT), "--data", str(tmp_path / "nope")],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1 and "view_distances.py: error:" in proc.stderr
    assert "nope" in proc.stderr


def test_target_points_are_the_models_draw(real_dataset, monkeypatch):
    monkeypatch.syspath_prepend(str(SCRIPT.parent))
    from view_distances import format_points, target_points

    whole = [
        int((shard.arrays(ci, e, ["global_align"])["global_align"] > 0).sum())
        for shard, ci, e in each_view(real_dataset)
    ]
    # a draw larger than every cloud keeps all of each view's target points
    assert list(target_points(real_dataset, 10**6)) == whole
    few = target_points(real_dataset, 64)
    assert (few <= np.minimum(whole, 64)).all() and (few >= 1).all()
    text = format_points(np.array([1.0, 2.5, 2.9, 5.0, 1.5]), np.array([9, 4, 6, 1, -1]), 64)
    assert "0-2 m: 1 views, median 9" in text and "2-3 m: 2 views, median 5" in text
    assert "3.8-10 m: 1 views, median 1" in text and "3-3.8 m" not in text
