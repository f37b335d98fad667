"""analyses/map_radial.py: a map's departure from the labels, by distance from the target."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "map_radial.py"


@pytest.fixture()
def radial(monkeypatch):
    monkeypatch.syspath_prepend(str(SCRIPT.parent))
    import map_radial

    return map_radial


def _floor(n: int = 4000, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Floor points around a target at the origin: (N, 2) xy and their distances."""
    xy = np.random.default_rng(seed).uniform(-1.5, 1.5, (n, 2))
    return xy, np.hypot(*xy.T)


def test_a_map_placed_farther_out_shows_as_a_shift_not_as_shape(radial):
    _, d = _floor()
    label = np.exp(-(((d - 0.6) / 0.08) ** 2))
    farther = np.exp(-(((d - 0.8) / 0.08) ** 2))
    row = radial.view_row(d, farther, label)
    assert row["shift_m"] == pytest.approx(0.2, abs=0.02)
    assert row["label_m"] == pytest.approx(0.6, abs=0.02)
    # A purely radial label is explained by distance alone; a map 20 cm out is not.
    assert row["ceiling_radial"] > 0.95 and row["pcc_radial"] < 0.2
    assert row["label_mass"].sum() == pytest.approx(1.0)
    assert row["label_mass"][radial.BINS.index(0.4)] > 0.4  # the 0.4-0.6 m ring holds mass


def test_a_label_that_depends_on_direction_lowers_the_radial_ceiling(radial):
    xy, d = _floor()
    band = np.exp(-(((d - 0.6) / 0.08) ** 2))
    one_side = band * (xy[:, 1] > 0)  # the other half blocked (an obstacle, a wall)
    row = radial.view_row(d, band, one_side)
    assert row["shift_m"] == pytest.approx(0.0, abs=0.02)
    assert row["pcc_radial"] > 0.99  # the right distances ...
    assert row["ceiling_radial"] < 0.8 and row["pcc"] < 0.8  # ... the wrong side


def test_constant_labels_are_left_out_and_robots_kept_apart(radial):
    _, d = _floor()
    assert radial.view_row(d, d, np.zeros_like(d)) is None
    label = np.exp(-(((d - 0.6) / 0.08) ** 2))
    rows = [("a", radial.view_row(d, label, label)), ("b", radial.view_row(d, d, label))]
    summary = radial.summarize(rows)
    assert summary["a"]["pcc"] == pytest.approx(1.0) and summary["a"]["views"] == 1
    assert summary["b"]["pcc"] < 0.5


def test_ring_average(radial):
    d = np.array([0.01, 0.02, 0.07, 0.30])
    v = np.array([1.0, 3.0, 5.0, 7.0])
    assert radial.ring_average(d, v).tolist() == [2.0, 2.0, 5.0, 7.0]


def test_a_bad_stride_is_one_line(small_dataset):
    cmd = [sys.executable, str(SCRIPT), "--data", str(small_dataset), "--every", "0"]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stderr == "map_radial.py: error: --every must be >= 1, got 0\n"
