"""A live RGB-D frame made into a model's clouds without trusting what the frame cannot
show (docs/SENSORS.md): the floor plane fitted to the frame, floor points put on it, the
target the depth-consistent part of its mask. Shared by ``predict``, the demo, the
robustness track and noise-aware training (``EpisodeDataset.use_sensor_noise``)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from momakitchen.errors import MomaError
from momakitchen.frames import transform_into
from momakitchen.perception.camera import CameraConfig, Intrinsics, backproject_into
from momakitchen.perception.clouds import CloudConfig, background, cloud_in_base, voxel_downsample
from momakitchen.perception.floor import (
    FloorCorrection,
    FloorFitConfig,
    fit_floor,
    floor_tolerance,
)

# Points this close to the fitted floor are tested against the floor's measured noise.
FLOOR_SEARCH = 0.1
FIT_STRIDE = 4  # the floor is fitted on one pixel in FIT_STRIDE**2


@dataclass(frozen=True)
class FrameClouds:
    """A live frame's model input (:func:`frame_inputs`), in the corrected base frame.

    Shapes: ``global_xyz`` (Ng, 3), ``global_rgb`` (Ng, 3) uint8, ``global_align`` (Ng,)
    int8, ``floor_xyz`` (Nf, 3) with z = 0, ``target_xyz`` (3,) the median of the target's
    depth-consistent points; ``correction``: the floor-plane correction applied.
    """

    global_xyz: np.ndarray
    global_rgb: np.ndarray
    global_align: np.ndarray
    floor_xyz: np.ndarray
    target_xyz: np.ndarray
    correction: FloorCorrection

    def arrays(self) -> dict[str, np.ndarray]:
        """The cloud arrays a model sample is made of (:func:`episode_sample`)."""
        return {
            "global_xyz": self.global_xyz,
            "global_rgb": self.global_rgb,
            "global_align": self.global_align,
            "floor_xyz": self.floor_xyz,
        }


def consistent_target(
    depth: np.ndarray, bin_width: float = 0.03, floor: float = 0.1, mode: float = 0.25
) -> np.ndarray:
    """The depth-consistent part of a target mask: the nearest depth mode that holds at
    least ``mode`` times the pixels of the largest one, with the depths around it down
    to ``floor`` times its count (a walk over a histogram of ``bin_width`` bins). A mask
    that spills onto, or is shifted onto, the wall behind the target, and flying pixels
    between the two, are left out (a segmenter's errors land on what lies behind the
    target more often than in front of it); a door seen at an angle, whose depths spread
    evenly, is kept whole.

    Shapes: ``depth`` (M,) the mask's valid depths (m) -> (M,) bool.
    """
    d = np.asarray(depth, np.float64)
    if len(d) < 3:
        return np.ones(len(d), bool)
    bins = np.floor((d - float(d.min())) / bin_width).astype(np.int64)
    # smoothed over three bins so that noise does not split one surface into modes
    smooth = np.convolve(np.bincount(bins), np.ones(3), mode="same")
    padded = np.r_[-1.0, smooth, -1.0]
    peaks = np.flatnonzero(
        (smooth >= padded[:-2]) & (smooth >= padded[2:]) & (smooth >= mode * smooth.max())
    )
    peak = int(peaks[0])
    enough = smooth >= floor * smooth[peak]
    first = peak
    while first > 0 and enough[first - 1]:
        first -= 1
    last = peak
    while last + 1 < len(enough) and enough[last + 1]:
        last += 1
    return (bins >= first) & (bins <= last)


def frame_inputs(
    depth: np.ndarray,
    valid: np.ndarray,
    rgb: np.ndarray,
    target_mask: np.ndarray,
    obstacle_masks: Sequence[np.ndarray],
    intrinsics: Intrinsics,
    camera_to_base: np.ndarray,
    cloud: CloudConfig | None = None,
    max_depth: float | None = None,
    *,
    floor: FloorFitConfig | None = None,
    metric_depth: bool = True,
) -> FrameClouds:
    """The model's clouds of one live RGB-D frame, built not to trust what the frame
    cannot show: the floor plane is fitted to the frame (the calibrated extrinsics only as
    a prior; :func:`~momakitchen.perception.floor.fit_floor`) and the points moved so it
    is z = 0; floor points (within the measured floor noise of the plane) are put on it,
    so per-point depth noise never reads as "a few millimetres up"; the target is the
    depth-consistent part of its mask (:func:`consistent_target`), and its points are
    always in the global cloud. MomaError names the cause when no floor plane is found,
    the mask has no pixel of valid depth, or the target lies beyond ``max_depth``.

    ``cloud`` and ``max_depth`` must be those the model was trained with (a loaded run's
    ``preprocessing``); None: the defaults (:class:`CloudConfig`, :class:`CameraConfig`).
    ``metric_depth`` False: the depth is known only up to scale (monocular), which the
    calibrated camera height then fixes.

    Shapes: ``depth`` (H, W) metres and ``valid`` (H, W) bool; ``rgb`` (H, W, 3) uint8;
    masks (H, W) bool; ``camera_to_base`` (4, 4).
    """
    cloud = cloud if cloud is not None else CloudConfig()
    max_depth = max_depth if max_depth is not None else CameraConfig().max_depth
    d = np.where(valid, depth, 0.0)
    flat_d = d.reshape(-1)
    mask2d = np.asarray(target_mask, bool)
    tmask = mask2d.reshape(-1)
    if not (tmask & (flat_d > 0) & (flat_d <= max_depth)).any():
        _no_target(d, mask2d, max_depth)
    tf = np.asarray(camera_to_base, np.float64)
    # The floor is fitted on every FIT_STRIDE-th pixel of each FIT_STRIDE-th row (plenty
    # for three parameters); the frame is then back-projected once, already corrected.
    grid = np.zeros(d.shape, bool)
    grid[::FIT_STRIDE, ::FIT_STRIDE] = True
    sub = np.flatnonzero(grid.reshape(-1) & (flat_d > 0) & (flat_d <= max_depth))
    rows = np.empty((3, len(sub)))
    backproject_into(flat_d, sub, intrinsics, rows)
    transform_into(tf, rows.copy(), rows)
    correction = fit_floor(rows.T, tf[:3, 3], floor, metric_depth, ranges=flat_d[sub])
    pts, idx = cloud_in_base(d, intrinsics, correction.matrix @ tf, max_depth)
    in_mask = tmask[idx]
    near = np.flatnonzero(np.abs(pts[:, 2]) < FLOOR_SEARCH)
    tol = floor_tolerance(pts[near, 2], flat_d[idx[near]] * correction.scale, cloud.floor_z)
    flat = near[np.abs(pts[near, 2]) <= tol]
    # Both clouds are thinned as the data's were (the points' heights decide their
    # voxels), then the floor is put on the plane: no per-point depth noise reaches the
    # model. A clean render thus gives the data's clouds, with the floor at z = 0.
    f_future = background(lambda: flat[voxel_downsample(pts[flat], cloud.floor_voxel)])
    keep = voxel_downsample(pts, cloud.voxel)
    f_pts = pts[f_future.result()]
    f_pts[:, 2] = 0.0
    pts[flat, 2] = 0.0
    if len(f_pts) == 0:
        raise MomaError(
            "no floor is visible (no point on the fitted floor plane)", cause="no_floor"
        )

    align = np.zeros(len(pts), np.int8)
    for m in obstacle_masks:
        align[np.asarray(m, bool).reshape(-1)[idx]] = -1
    t_rows = np.flatnonzero(in_mask)
    t_rows = t_rows[consistent_target(flat_d[idx[t_rows]])]
    align[t_rows] = 1
    if not (align[keep] > 0).any():  # a small target thinned away: its own voxels
        t_keep = t_rows[voxel_downsample(pts[t_rows], cloud.voxel)]
        keep = np.union1d(keep, t_keep)
    target = np.median(pts[t_rows], axis=0)
    return FrameClouds(
        global_xyz=pts[keep],
        global_rgb=rgb.reshape(-1, 3)[idx[keep]],
        global_align=align[keep],
        floor_xyz=f_pts,
        target_xyz=target,
        correction=correction,
    )


def _no_target(depth: np.ndarray, mask: np.ndarray, max_depth: float) -> None:
    """Raise the MomaError that says why the target has no point in the clouds."""
    n = int(mask.sum())
    if n == 0:
        raise MomaError("the target mask is empty (0 pixels)", cause="empty_mask")
    dm = depth[mask]
    good = dm[dm > 0]
    if len(good) == 0:
        raise MomaError(
            f"the target mask has {n} pixels but none with a valid depth (the target may "
            "be beyond the depth sensor's range: move closer)",
            cause="no_target_depth",
        )
    raise MomaError(
        f"the target is {float(np.median(good)):.2f} m away, beyond the "
        f"{_length(max_depth)} the model uses: move closer",
        cause="target_range",
    )


def _length(metres: float) -> str:
    """A threshold for messages: centimetres below 1 m (``2 cm``), else metres (``6 m``)."""
    if metres < 1:
        return f"{metres * 100:g} cm"
    return f"{metres:g} m"
