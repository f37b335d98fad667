"""2-D footprint geometry on the floor plane (pure NumPy).

Footprints are oriented rectangles: centre (x, y), yaw, and full extents (length along the
rectangle's own x axis, width along its y axis).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Footprint:
    """An oriented rectangle on the floor: centre, yaw (rad) and full extents (m)."""

    x: float
    y: float
    yaw: float
    length: float
    width: float

    def corners(self) -> np.ndarray:
        """Corner coordinates, counter-clockwise. Shape (4, 2)."""
        return box_corners(self.x, self.y, self.yaw, self.length, self.width)[0]

    def inflated(self, margin: float) -> Footprint:
        """The same rectangle grown by ``margin`` on every side."""
        grow = 2 * margin
        return Footprint(self.x, self.y, self.yaw, self.length + grow, self.width + grow)


def box_corners(x, y, yaw, length, width) -> np.ndarray:
    """Corners of oriented rectangles, counter-clockwise; arguments broadcast.

    Shapes: scalars or (N,) arrays in; (N, 4, 2) out.
    """
    x, y, yaw, length, width = np.broadcast_arrays(
        *(np.atleast_1d(np.asarray(v, float)) for v in (x, y, yaw, length, width))
    )
    c, s = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
    lx = np.stack([length, -length, -length, length], axis=1) / 2  # (N, 4)
    ly = np.stack([width, width, -width, -width], axis=1) / 2
    return np.stack([x[:, None] + c * lx - s * ly, y[:, None] + s * lx + c * ly], axis=-1)


def corners_of(footprints: list[Footprint] | tuple[Footprint, ...]) -> np.ndarray:
    """Stacked corners of several footprints. Shape (N, 4, 2)."""
    if not footprints:
        return np.zeros((0, 4, 2))
    return np.stack([f.corners() for f in footprints])


def overlap_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Separating-axis test between every rectangle of ``a`` and every one of ``b``.

    Shapes: ``a`` (N, 4, 2) and ``b`` (M, 4, 2) corners, counter-clockwise; returns (N, M)
    bool, True where the rectangles overlap (touching counts as apart).
    """
    if len(a) == 0 or len(b) == 0:
        return np.zeros((len(a), len(b)), dtype=bool)

    def axes(c: np.ndarray) -> np.ndarray:  # (K, 2, 2): two edge normals per rectangle
        e = c[:, 1:3] - c[:, 0:2]
        return np.stack([-e[..., 1], e[..., 0]], axis=-1)

    n, m = len(a), len(b)
    ax = np.concatenate(
        [
            np.broadcast_to(axes(a)[:, None], (n, m, 2, 2)),
            np.broadcast_to(axes(b)[None], (n, m, 2, 2)),
        ],
        axis=2,
    )  # (N, M, 4, 2)
    pa = np.einsum("nmkd,ncd->nmkc", ax, a)  # projections of a's corners on each axis
    pb = np.einsum("nmkd,mcd->nmkc", ax, b)
    separated = (pa.max(-1) <= pb.min(-1)) | (pb.max(-1) <= pa.min(-1))
    return ~separated.any(-1)


def overlaps(a: Footprint, b: Footprint) -> bool:
    """True if the two rectangles overlap (touching counts as apart)."""
    return bool(overlap_matrix(a.corners()[None], b.corners()[None])[0, 0])


def semicircle_grid(
    center: tuple[float, float], radius: float, spacing: float, facing: float = np.pi / 2
) -> np.ndarray:
    """Grid points inside the half-disc in front of ``center``.

    The half-disc has radius ``radius`` and is centred on direction ``facing`` (rad, world
    frame; pi/2 = +y, away from a wall at y = 0). Grid lines are aligned with the world axes
    at multiples of ``spacing`` (so neighbouring targets share grid lines).

    Returns:
        Points of shape (P, 2), sorted by (x, y).
    """
    cx, cy = center
    lo_x = np.floor((cx - radius) / spacing) * spacing
    lo_y = np.floor((cy - radius) / spacing) * spacing
    nx = int(np.ceil(2 * radius / spacing)) + 2
    xs = np.round(lo_x + spacing * np.arange(nx), 6)
    ys = np.round(lo_y + spacing * np.arange(nx), 6)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    pts = np.stack([gx.ravel(), gy.ravel()], axis=1)
    rel = pts - np.array(center)
    dist = np.linalg.norm(rel, axis=1)
    ahead = rel @ np.array([np.cos(facing), np.sin(facing)])
    keep = (dist <= radius + 1e-9) & (ahead > 1e-9)
    return pts[keep]
