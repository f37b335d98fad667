"""Cloud building: the threaded, in-place base-frame cloud equals the plain formulas."""

import numpy as np
import pytest

from momakitchen.errors import MomaError
from momakitchen.frames import base_to_world, transform
from momakitchen.perception.camera import Intrinsics, backproject
from momakitchen.perception.clouds import cloud_in_base


def test_cloud_in_base_equals_backproject_then_transform():
    rng = np.random.default_rng(3)
    intr = Intrinsics(300.0, 310.0, 80.5, 59.5, 161, 121)
    depth = rng.uniform(0.2, 8.0, (121, 161)).astype(np.float32)
    depth[rng.random(depth.shape) < 0.1] = 0.0
    depth[rng.random(depth.shape) < 0.05] = np.nan
    depth[rng.random(depth.shape) < 0.02] = np.inf
    tf = base_to_world((0.3, -0.2, 0.7))
    tf[:3, 3] += [0.1, 0.0, 1.2]
    pts, idx = cloud_in_base(depth, intr, tf, max_depth=6.0)
    ref_pts, ref_idx = backproject(np.where(depth <= 6.0, depth, 0.0), intr)
    assert np.array_equal(idx, ref_idx)
    assert np.array_equal(pts, transform(tf, ref_pts))  # bit for bit
    assert np.all(depth.reshape(-1)[idx] <= 6.0) and len(idx) < depth.size * 0.9


def test_cloud_in_base_rejects_a_depth_of_another_size():
    with pytest.raises(MomaError, match="does not match"):
        cloud_in_base(np.ones((10, 12)), Intrinsics(10, 10, 6, 5, 12, 11), np.eye(4), 6.0)
