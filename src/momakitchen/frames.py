"""Frame transforms: robot base frames on the floor, rigid transforms of points, URDF
roll-pitch-yaw rotations.

A robot base frame is ``(x, y, yaw)`` on the floor: x forward, y left, z up, z = 0 on the
floor. Camera frames use OpenCV axes (x right, y down, z forward).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

import numpy as np


def float3(values: Iterable[float]) -> tuple[float, float, float]:
    """Three numbers as a tuple of Python floats (a base pose ``x, y, yaw`` or a point)."""
    x, y, z = (float(v) for v in values)
    return (x, y, z)


def rpy_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """URDF fixed-axis roll-pitch-yaw to a rotation matrix: Rz(yaw) Ry(pitch) Rx(roll).

    Shapes: three scalars -> (3, 3).
    """
    cr, sr, cp, sp, cy, sy = (
        math.cos(roll),
        math.sin(roll),
        math.cos(pitch),
        math.sin(pitch),
        math.cos(yaw),
        math.sin(yaw),
    )
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def transform(tf: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Apply a (4, 4) rigid transform to points. Shapes: (N, 3) -> (N, 3).

    Written as three multiply-adds per axis: a BLAS matrix product on an (N, 3) array
    costs 15x more CPU here (its threads spin on a busy machine). The result is a
    transposed (3, N) array, so each coordinate is contiguous; with such an input (as
    :func:`backproject` returns) every operation runs on contiguous memory.
    """
    pts = np.asarray(points, float).T
    out = np.empty((3, pts.shape[1]))
    transform_into(tf, pts, out)
    return out.T


def transform_into(tf: np.ndarray, rows: np.ndarray, out: np.ndarray) -> None:
    """Apply a (4, 4) rigid transform to points given as rows (3, n) x, y, z, writing the
    rows of the result into ``out`` (3, n):
    ``out[i] = x * tf[i, 0] + y * tf[i, 1] + z * tf[i, 2] + tf[i, 3]``, in that order,
    in place."""
    tmp = np.empty(rows.shape[1])
    for i, o in enumerate(out):
        np.multiply(rows[0], tf[i, 0], out=o)
        for j in (1, 2):
            np.multiply(rows[j], tf[i, j], out=tmp)
            o += tmp
        o += tf[i, 3]


def base_to_world(base: tuple[float, float, float]) -> np.ndarray:
    """Transform (4, 4) of a robot base frame at ``(x, y, yaw)`` on the floor."""
    x, y, yaw = base
    tf = np.eye(4)
    c, s = np.cos(yaw), np.sin(yaw)
    tf[:2, :2] = [[c, -s], [s, c]]
    tf[:2, 3] = [x, y]
    return tf


def world_to_base(points: np.ndarray, base: tuple[float, float, float]) -> np.ndarray:
    """Express world floor points in a robot base frame (x forward, y left).

    Shapes: ``points`` (N, 2) or (N, 3) world; ``base`` = (x, y, yaw); returns same shape.
    """
    pts = np.asarray(points, float)
    x, y, yaw = base
    c, s = np.cos(yaw), np.sin(yaw)
    out = pts.copy()
    dx, dy = pts[:, 0] - x, pts[:, 1] - y
    out[:, 0] = c * dx + s * dy
    out[:, 1] = -s * dx + c * dy
    return out


def base_to_world_xy(points: np.ndarray, base: Sequence[float]) -> np.ndarray:
    """Floor points (N, 2) of a viewpoint's base frame ``(x, y, yaw)`` to world xy (N, 2)."""
    pts = np.asarray(points, np.float64).reshape(-1, 2)
    return transform(base_to_world(float3(base)), np.column_stack([pts, np.zeros(len(pts))]))[:, :2]
