"""analyses/descriptor_ablation.py: the same views scored with a descriptor column replaced."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np

SCRIPT = Path(__file__).resolve().parents[1] / "descriptor_ablation.py"


def _run(*args: str | Path) -> subprocess.CompletedProcess:
    cmd = [sys.executable, str(SCRIPT), *map(str, args)]
    return subprocess.run(cmd, capture_output=True, text=True, check=False)


def test_a_replaced_column_moves_the_map_and_the_stored_one_does_not(small_dataset, tmp_path):
    out = tmp_path / "ablation"
    res = _run(
        "--data",
        small_dataset,
        "--out",
        out,
        "--variant",
        "reach_m=0.4",
        "--variant",
        "reach_m=0.85,mount_height_m=1.03",
    )
    assert res.returncode == 0, res.stderr
    assert "| reach_m=0.4 |" in res.stdout
    stored = np.load(out / "stored.npz")
    short = np.load(out / "reach_m-0.4.npz")
    assert sorted(stored.files) == sorted(short.files) and len(stored.files) == 6
    moved = [np.abs(stored[k] - short[k]).mean() for k in stored.files]
    assert min(moved) > 0 and max(moved) > 1e-3  # the model reads the reach
    for k in stored.files:
        assert stored[k].dtype == np.float32 and 0 <= stored[k].min() <= stored[k].max() <= 1
    # scoring the stored descriptor twice gives the same maps
    again = _run("--data", small_dataset, "--out", tmp_path / "again")
    assert again.returncode == 0, again.stderr
    for k in stored.files:
        np.testing.assert_array_equal(np.load(tmp_path / "again" / "stored.npz")[k], stored[k])


def test_a_column_the_model_does_not_read_is_one_line(small_dataset, tmp_path):
    res = _run("--data", small_dataset, "--out", tmp_path, "--variant", "shoulder_height_m=1")
    assert res.returncode == 2
    assert res.stderr.strip().count("\n") == 0
    assert "no column 'shoulder_height_m' (the model reads" in res.stderr
