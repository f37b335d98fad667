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
        c, s = np.cos(self.yaw), np.sin(self.yaw)
        hx, hy = self.length / 2, self.width / 2
        local = np.array([[hx, hy], [-hx, hy], [-hx, -hy], [hx, -hy]])
        rot = np.array([[c, -s], [s, c]])
        return local @ rot.T + np.array([self.x, self.y])

    def inflated(self, margin: float) -> Footprint:
        """The same rectangle grown by ``margin`` on every side."""
        grow = 2 * margin
        return Footprint(self.x, self.y, self.yaw, self.length + grow, self.width + grow)


def _axes(corners: np.ndarray) -> np.ndarray:
    edges = np.roll(corners, -1, axis=0) - corners
    normals = np.stack([-edges[:, 1], edges[:, 0]], axis=1)
    return normals[:2] / np.linalg.norm(normals[:2], axis=1, keepdims=True)


def overlaps(a: Footprint, b: Footprint) -> bool:
    """Separating-axis test: True if the two rectangles overlap (touching counts as apart)."""
    ca, cb = a.corners(), b.corners()
    for axis in np.concatenate([_axes(ca), _axes(cb)]):
        pa, pb = ca @ axis, cb @ axis
        if pa.max() <= pb.min() or pb.max() <= pa.min():
            return False
    return True


def overlaps_any(a: Footprint, others: list[Footprint] | tuple[Footprint, ...]) -> bool:
    """True if ``a`` overlaps any footprint in ``others``."""
    return any(overlaps(a, b) for b in others)


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
