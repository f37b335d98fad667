"""Obstacle points from depth: a box on the floor in front of a camera keeps its points,
the floor's are dropped, invalid depth is skipped."""

from __future__ import annotations

import numpy as np
import pytest

from momakitchen.errors import MomaError
from momakitchen.perception.camera import Intrinsics, look_at
from momakitchen.perception.obstacles import obstacle_points

BOX_LO, BOX_HI = np.array([1.5, -0.2, 0.0]), np.array([1.8, 0.25, 0.5])


def _render() -> tuple[np.ndarray, Intrinsics, np.ndarray, np.ndarray]:
    """Depth (along the optical axis) of a box on the floor plane z = 0, seen from a camera
    1.2 m above the base's origin looking at the box; the camera-to-base transform, and
    which pixels see the box."""
    intr = Intrinsics.from_fov(160, 120, 60.0)
    tf = look_at(np.array([0.0, 0.0, 1.2]), np.array([1.6, 0.0, 0.2]))
    v, u = np.mgrid[0 : intr.height, 0 : intr.width]
    rays = np.stack([(u - intr.cx) / intr.fx, (v - intr.cy) / intr.fy, np.ones(u.shape)], -1)
    d = rays @ tf[:3, :3].T  # base-frame direction per unit of depth
    o = tf[:3, 3]
    with np.errstate(divide="ignore", invalid="ignore"):
        floor = np.where(d[..., 2] < 0, -o[2] / d[..., 2], np.inf)
        t0 = (BOX_LO - o) / d
        t1 = (BOX_HI - o) / d
    near = np.minimum(t0, t1).max(-1)
    far = np.maximum(t0, t1).min(-1)
    on_box = (near <= far) & (near > 0)
    depth = np.where(on_box, near, floor)
    depth[~np.isfinite(depth)] = 0.0
    return depth, intr, tf, on_box & (near < floor)


def test_the_box_is_kept_the_floor_dropped():
    depth, intr, tf, on_box = _render()
    assert on_box.sum() > 500 and (~on_box & (depth > 0)).sum() > 5000
    xy = obstacle_points(depth, intr, tf)
    assert xy.shape[1] == 2 and xy.dtype == np.float64
    tol = 1e-9
    assert (xy >= BOX_LO[:2] - tol).all() and (xy <= BOX_HI[:2] + tol).all()
    # All the box's pixels but those of its lowest 5 cm.
    assert 0.8 * on_box.sum() < len(xy) <= on_box.sum()
    low = obstacle_points(depth, intr, tf, max_height=0.3)
    assert 0 < len(low) < len(xy)
    high = obstacle_points(depth, intr, tf, min_height=0.3)
    assert 0 < len(high) < len(xy) and len(low) + len(high) <= len(xy)


def test_invalid_depth_is_skipped():
    depth, intr, tf, on_box = _render()
    rng = np.random.default_rng(0)
    bad = rng.random(depth.shape) < 0.2
    holes = depth.copy()
    holes[bad] = np.nan
    holes[bad & (rng.random(depth.shape) < 0.5)] = 0.0
    xy = obstacle_points(holes, intr, tf)
    assert np.isfinite(xy).all()
    np.testing.assert_array_equal(xy, obstacle_points(np.where(bad, 0.0, depth), intr, tf))
    assert 0.6 * on_box.sum() < len(xy) < 0.9 * on_box.sum()


def test_the_target_and_far_points_are_left_out():
    depth, intr, tf, on_box = _render()
    assert len(obstacle_points(depth, intr, tf, exclude_mask=on_box)) == 0
    half = on_box & (np.arange(depth.shape[1]) < depth.shape[1] // 2)
    kept = obstacle_points(depth, intr, tf, exclude_mask=half)
    assert 0 < len(kept) < len(obstacle_points(depth, intr, tf))
    assert len(obstacle_points(depth, intr, tf, max_range=1.0)) == 0  # the box is ~1.7 m off


def test_bad_arguments():
    depth, intr, tf, _ = _render()
    with pytest.raises(MomaError, match="max_height"):
        obstacle_points(depth, intr, tf, min_height=0.5, max_height=0.2)
    with pytest.raises(MomaError, match="max_range"):
        obstacle_points(depth, intr, tf, max_range=0.0)
    with pytest.raises(MomaError, match="exclude_mask"):
        obstacle_points(depth, intr, tf, exclude_mask=np.zeros((3, 3), bool))
    with pytest.raises(MomaError, match="camera_to_base"):
        obstacle_points(depth, intr, np.eye(3))
