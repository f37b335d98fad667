"""Cloud building: the threaded, in-place base-frame cloud equals the plain formulas; the
allocator setting for image-sized arrays."""

import os
import subprocess
import sys

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


# Five 8 MB arrays made and freed 20 times, after a first round: minor page faults.
_ALLOCATE = """
import resource, sys
import numpy as np
from momakitchen.perception.clouds import reuse_freed_memory
applied = reuse_freed_memory() if sys.argv[1] == "1" else None
def work():
    for _ in range(20):
        arrays = [np.ones(1_000_000) for _ in range(5)]
        del arrays
work()
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
work()
print(applied, resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""


def _faults(tuned: bool, **env: str) -> tuple[str, int]:
    clean = {k: v for k, v in os.environ.items() if not k.startswith("MALLOC_")}
    out = subprocess.run(
        [sys.executable, "-c", _ALLOCATE, "1" if tuned else "0"],
        check=True,
        capture_output=True,
        text=True,
        env=clean | env,
    ).stdout.split()
    return out[0], int(out[1])


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's mallopt")
def test_reuse_freed_memory_keeps_freed_arrays_for_the_next_ones():
    applied, faults = _faults(True)
    assert applied == "True"
    _, default = _faults(False)
    # 20 rounds of 40 MB: the default allocator hands most of it back and faults it in again
    assert faults < 1000 < default
    # a user's own allocator settings are kept
    applied, faults = _faults(True, MALLOC_ARENA_MAX="2")
    assert applied == "False" and faults > 1000
