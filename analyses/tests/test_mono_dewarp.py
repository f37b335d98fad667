"""analyses/mono_dewarp.py: the smooth warp of relative depth, read from a flat floor."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np

from momakitchen.perception.camera import Intrinsics, look_at
from momakitchen.perception.clouds import cloud_in_base
from momakitchen.perception.floor import fit_floor

ANALYSES = Path(__file__).resolve().parents[1]


def _floor_depth(intr: Intrinsics, tf: np.ndarray) -> np.ndarray:
    """Depth (along the optical axis) of the plane z = 0 at every pixel. (H, W)."""
    v, u = np.indices((intr.height, intr.width))
    rays = np.stack([(u - intr.cx) / intr.fx, (v - intr.cy) / intr.fy, np.ones(u.shape)], -1)
    world = rays @ tf[:3, :3].T  # ray direction per unit of depth
    with np.errstate(divide="ignore"):
        depth = -tf[2, 3] / world[..., 2]
    return np.where((world[..., 2] < 0) & (depth < 8.0), depth, 0.0)


def test_a_quadratic_warp_of_the_floor_is_read_back(monkeypatch):
    monkeypatch.syspath_prepend(str(ANALYSES))
    from mono_dewarp import warp_field

    intr = Intrinsics.from_fov(160, 120, 58.0)
    tf = look_at([0.0, 0.0, 1.2], [2.5, 0.0, 0.0])
    true = _floor_depth(intr, tf)
    v, u = np.indices(true.shape)
    x, y = 2 * u / intr.width - 1, 2 * v / intr.height - 1
    warp = 1.0 + 0.03 * (0.6 * x - 0.5 * y * y + 0.4 * x * y)
    # a box on the floor: its pixels must not be read as a warp
    box = (abs(u - 80) < 12) & (v > 70) & (v < 90)
    measured = np.where(box, true * 0.9, true) * warp * 1.06  # and a global scale error
    pts = cloud_in_base(measured, intr, tf, 20.0)[0]
    correction = fit_floor(pts[::4], tf[:3, 3], metric=False)
    bad = SimpleNamespace(depth=measured, intrinsics=intr, camera_to_base=tf)
    field = warp_field(bad, SimpleNamespace(correction=correction))
    assert field is not None and field.shape == true.shape
    floor = (true > 0) & ~box
    # with the calibration right, the field gives the floor its true depth back
    assert np.abs(measured[floor] * field[floor] / true[floor] - 1).max() < 0.004
    # which the one scale alone does not
    assert np.abs(measured[floor] * correction.scale / true[floor] - 1).max() > 0.02
    # never extrapolated beyond the values the floor showed
    assert field.min() >= field[floor].min() - 1e-12 and field.max() <= field[floor].max() + 1e-12


def test_a_pitch_error_is_read_as_a_warp(monkeypatch):
    """Relative depth cannot tell a calibration's pitch error from a warp: the floor of a
    camera pitched 1 degree more than calibrated, with exact depth, reads as warped."""
    monkeypatch.syspath_prepend(str(ANALYSES))
    from mono_dewarp import warp_field

    intr = Intrinsics.from_fov(160, 120, 58.0)
    calibrated = look_at([0.0, 0.0, 1.2], [2.5, 0.0, 0.0])
    down = np.arctan2(1.2, 2.5) + np.radians(1.0)
    real = look_at([0.0, 0.0, 1.2], [2.5, 0.0, 1.2 - 2.5 * np.tan(down)])
    depth = _floor_depth(intr, real)
    pts = cloud_in_base(depth, intr, calibrated, 20.0)[0]
    correction = fit_floor(pts[::4], calibrated[:3, 3], metric=False)
    bad = SimpleNamespace(depth=depth, intrinsics=intr, camera_to_base=calibrated)
    field = warp_field(bad, SimpleNamespace(correction=correction))
    seen = field[depth > 0]
    assert np.abs(seen / np.median(seen) - 1).max() > 0.01


def test_too_little_floor_reads_no_warp(monkeypatch):
    monkeypatch.syspath_prepend(str(ANALYSES))
    from mono_dewarp import warp_field

    intr = Intrinsics.from_fov(160, 120, 58.0)
    tf = look_at([0.0, 0.0, 1.2], [2.5, 0.0, 0.0])
    depth = _floor_depth(intr, tf)
    correction = fit_floor(cloud_in_base(depth, intr, tf, 20.0)[0], tf[:3, 3], metric=False)
    few = np.zeros_like(depth)
    few[-2:, :10] = depth[-2:, :10]  # 20 floor pixels
    bad = SimpleNamespace(depth=few, intrinsics=intr, camera_to_base=tf)
    assert warp_field(bad, SimpleNamespace(correction=correction)) is None
