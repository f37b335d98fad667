"""analyses/mask_band.py: the floor the standable mask takes from the maps, checked in PyBullet."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from momakitchen.data.manifest import load_manifest
from momakitchen.data.shard import SceneShard
from momakitchen.errors import MomaError

ANALYSES = Path(__file__).resolve().parents[1]


def test_band_is_what_the_labels_mask_and_the_floor_plan_is_conservative(real_dataset, monkeypatch):
    monkeypatch.syspath_prepend(str(ANALYSES))
    from mask_band import count

    totals = count(real_dataset, every=1, sample=10_000)  # every point checked
    positive, masked, band, free, kept, hit = (int(v) for v in totals["all"])
    # The labels are the interpolation with the mask applied: their positive points are
    # exactly the unmasked ones.
    labelled = 0
    for entry in load_manifest(real_dataset)["shards"].values():
        with SceneShard(real_dataset / entry["file"]) as shard:
            for ci in range(len(entry["episodes_per_config"])):
                for e in shard.episode_indices(ci):
                    labelled += int((shard.episode(ci, e).floor_label > 0).sum())
    assert 0 < labelled == positive - masked
    assert (band, kept) == (masked, positive - masked)
    assert hit == 0  # nowhere the floor plan lets the base stand does PyBullet find it colliding
    assert 0 <= free <= band
    assert sum(v for k, v in totals.items() if k != "all").tolist() == totals["all"].tolist()
    again = count(real_dataset, every=1, sample=3)
    assert (again["all"][:2] == totals["all"][:2]).all() and again["all"][2] <= 3 * 4
    assert all((v == count(real_dataset, 1, 3)[k]).all() for k, v in again.items())


def test_bad_input_is_one_line_and_status_2(tmp_path, monkeypatch):
    res = subprocess.run(
        [sys.executable, str(ANALYSES / "mask_band.py"), "--data", str(tmp_path / "none")],
        capture_output=True,
        text=True,
    )
    assert res.returncode == 2
    assert res.stderr.count("\n") == 1 and res.stderr.startswith("mask_band.py: error:")
    assert "none" in res.stderr
    monkeypatch.syspath_prepend(str(ANALYSES))
    from mask_band import main

    for flag in ("--every", "--sample"):
        monkeypatch.setattr(sys, "argv", ["mask_band.py", "--data", str(tmp_path), flag, "0"])
        with pytest.raises(MomaError, match=f"{flag} must be >= 1, got 0"):
            main()
