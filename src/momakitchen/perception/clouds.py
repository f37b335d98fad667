"""Point clouds from RGB-D frames: back-projection, base frame, voxel down-sampling."""

from __future__ import annotations

import ctypes
import os
import sys
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

import numpy as np

from momakitchen.errors import MomaError
from momakitchen.frames import transform_into
from momakitchen.perception.camera import Intrinsics, backproject_into, check_depth_shape

_POOL: tuple[int, ThreadPoolExecutor] | None = None


def background(fn: Callable[..., Any], *args: Any) -> Future:
    """Run ``fn(*args)`` on this process's helper thread. NumPy releases the GIL inside
    its loops over large arrays, so cloud building overlaps two such tasks on two cores.
    (A forked child gets a new thread: threads do not survive fork.)"""
    global _POOL
    if _POOL is None or _POOL[0] != os.getpid():
        _POOL = (os.getpid(), ThreadPoolExecutor(1, thread_name_prefix="momakitchen-clouds"))
    return _POOL[1].submit(fn, *args)


# glibc mallopt parameters (malloc.h).
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3


def reuse_freed_memory() -> bool:
    """Let this process (and the DataLoader workers it forks later) reuse freed memory
    for the next frame's image-sized arrays instead of handing it back to the kernel:
    glibc's defaults unmap or trim a freed array of a few MB, and the next frame's array
    is a fresh page fault per 4 kB, about a tenth of a noisy training sample's CPU time
    (BENCHMARKS.md). Keeps at most 256 MB freed per process. The samples are the same
    bytes (the allocator only places the arrays; ``benchmarks/bench_noisy_sample.py``
    compares them).

    Returns whether the setting was applied: False off glibc, or where the user set the
    allocator through ``MALLOC_*`` environment variables (theirs is kept).
    """
    if not sys.platform.startswith("linux") or any(k.startswith("MALLOC_") for k in os.environ):
        return False
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):  # not glibc (musl has no mallopt)
        return False
    # A fixed mmap threshold keeps arrays below 32 MB (glibc's bound) in the heap; the
    # trim threshold keeps up to 256 MB of its freed top for reuse.
    mmap = mallopt(_M_MMAP_THRESHOLD, 32 << 20)
    return bool(mmap) and bool(mallopt(_M_TRIM_THRESHOLD, 256 << 20))


def voxel_downsample(points: np.ndarray, voxel: float) -> np.ndarray:
    """Indices of one representative point per occupied voxel (deterministic: the first
    point, in input order, of each voxel; returned sorted).

    Shapes: ``points`` (N, 3) -> indices (M,) with M <= N.
    """
    if len(points) == 0 or voxel <= 0:
        return np.arange(len(points))
    scaled = np.divide(points, voxel)
    cells = np.floor(scaled, out=scaled).astype(np.int64)
    cells -= cells.min(axis=0)
    span = cells.max(axis=0) + 1
    # One integer key per voxel; an unstable sort groups the voxels (3x faster than the
    # stable sort behind np.unique(return_index=True)), and the smallest original index
    # of each group is its first point. Computed in place: fresh large arrays cost a page
    # fault per 4 kB.
    keys = np.multiply(cells[:, 0], span[1])
    keys += cells[:, 1]
    keys *= span[2]
    keys += cells[:, 2]
    # Points from an image come in pixel order, and neighbouring pixels mostly share a
    # voxel: only the first point of each run of equal keys can be a voxel's first point,
    # so the sort runs on those (3-5x fewer for a 640x480 frame; the result is the same).
    runs = np.flatnonzero(np.r_[True, keys[1:] != keys[:-1]])
    keys = keys[runs]
    order = np.argsort(keys)
    sorted_keys = keys[order]
    starts = np.flatnonzero(np.r_[True, sorted_keys[1:] != sorted_keys[:-1]])
    return runs[np.sort(np.minimum.reduceat(order, starts))]


def cloud_in_base(
    depth: np.ndarray, intrinsics: Intrinsics, camera_to_base: np.ndarray, max_depth: float
) -> tuple[np.ndarray, np.ndarray]:
    """Back-project valid pixels (0 < depth <= max_depth; NaN and inf are invalid) into the
    robot base frame: :func:`~momakitchen.perception.camera.backproject` then
    :func:`~momakitchen.perception.camera.transform`, the same arithmetic, each half of
    the pixels on its own thread.

    Returns points (N, 3) float64 in the base frame (a transposed (3, N) array) and their
    flat pixel indices (N,).
    """
    check_depth_shape(depth, intrinsics)
    flat = depth.reshape(-1)
    idx = np.flatnonzero((flat > 0) & (flat <= max_depth))  # False for NaN
    out = np.empty((3, len(idx)))

    def part(sl: slice) -> None:
        cam = np.empty((3, len(idx[sl])))
        backproject_into(flat, idx[sl], intrinsics, cam)
        transform_into(camera_to_base, cam, out[:, sl])

    half = len(idx) // 2
    first = background(part, slice(0, half))
    part(slice(half, len(idx)))
    first.result()
    return out.T, idx


@dataclass(frozen=True)
class CloudConfig:
    """Point-cloud extraction (metres).

    Attributes:
        voxel: voxel size of the global cloud down-sampling.
        floor_voxel: voxel size of the floor cloud.
        floor_z: points below this height in the base frame are floor points.
    """

    voxel: float = 0.02
    floor_voxel: float = 0.03
    floor_z: float = 0.02

    def __post_init__(self) -> None:
        for name in ("voxel", "floor_voxel", "floor_z"):
            if not 0 < getattr(self, name) <= 0.5:
                raise MomaError(
                    f"CloudConfig.{name} must be in (0, 0.5] m, got {getattr(self, name)}"
                )


def frame_clouds(
    depth: np.ndarray,
    rgb: np.ndarray,
    align: np.ndarray,
    intrinsics: Intrinsics,
    camera_to_base: np.ndarray,
    cloud: CloudConfig,
    max_depth: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The global and floor clouds of one RGB-D frame, in the robot base frame.

    Used for generated views and for live frames (:func:`momakitchen.predict`) alike, so
    a model sees the same clouds from both. Pixels with depth 0, NaN or beyond
    ``max_depth`` are skipped.

    Shapes:
        - input: ``depth`` (H, W) metres, ``rgb`` (H, W, 3) uint8, ``align`` (H, W) int8
          (+1 target, -1 obstacle, 0 else), ``camera_to_base`` (4, 4)
        - output: global xyz (Ng, 3) float64, global rgb (Ng, 3) uint8, global alignment
          (Ng,) int8, floor xyz (Nf, 3) float64 (points below ``cloud.floor_z``)
    """
    pts, idx = cloud_in_base(depth, intrinsics, camera_to_base, max_depth)

    def floor() -> np.ndarray:
        f_pts = pts[pts[:, 2] < cloud.floor_z]
        return f_pts[voxel_downsample(f_pts, cloud.floor_voxel)]

    f_future = background(floor)  # the floor cloud on the helper thread meanwhile
    keep = voxel_downsample(pts, cloud.voxel)
    g_idx = idx[keep]
    return pts[keep], rgb.reshape(-1, 3)[g_idx], align.reshape(-1)[g_idx], f_future.result()
