"""Where an articulated target is grasped and the floor its part sweeps while it opens
(world frame, from the placed unit's URDF; pure NumPy)."""

from __future__ import annotations

import numpy as np

from momakitchen.assets.urdf_frames import joint_axes, link_extent_points, link_rest_poses
from momakitchen.frames import float3
from momakitchen.scene.layout import Layout, Placed, _r


def handle_anchor(unit: Placed, articulation: int) -> tuple[float, float, float]:
    """World position of an articulated part's grasp point with the part closed."""
    model = unit.model
    art = model.articulations[articulation]
    link_pose = link_rest_poses(model.urdf)[art.handle.link]
    local = link_pose[:3, :3] @ np.asarray(art.handle.position) + link_pose[:3, 3]
    return float3(_r(v) for v in unit.to_world(local))


# At least what the trials pull (TrialConfig's pull_angle_deg and pull_distance), with
# room to spare: the floor the part sweeps while opening that far stays free of obstacles.
PART_SWEEP = (np.radians(45.0), 0.16)


def part_sweep(unit: Placed, articulation: int, margin: float = 0.1) -> np.ndarray:
    """Corners (1, 4, 2) of the world-axis-aligned floor rectangle that an articulated
    part (its whole panel or drawer box, and its handle) passes over while it opens by
    :data:`PART_SWEEP` (a door's arc, a drawer's travel), together with its hinge, grown
    by ``margin``."""
    model = unit.model
    art = model.articulations[articulation]
    child, axis_local = joint_axes(model.urdf)[art.joint]
    poses = link_rest_poses(model.urdf)
    joint_frame, handle_frame = poses[child], poses[art.handle.link]
    origin = joint_frame[:3, 3]
    axis = joint_frame[:3, :3] @ axis_local
    axis = axis / max(float(np.linalg.norm(axis)), 1e-9)
    handle = handle_frame[:3, :3] @ np.asarray(art.handle.position) + handle_frame[:3, 3]
    # The panel's corners as well as the handle: a pull-down door or a drawer is as wide
    # as the unit, far wider than its handle.
    panel = link_extent_points(model.urdf, child) @ joint_frame[:3, :3].T + joint_frame[:3, 3]
    amount = PART_SWEEP[0] if art.joint_type == "revolute" else PART_SWEEP[1]
    amount = min(amount, art.limit) if art.limit > 0 else amount
    points = [origin]
    moving = np.vstack([handle, panel])
    for s in np.linspace(0.0, amount, 6) * art.open_direction:
        if art.joint_type == "revolute":  # Rodrigues: turned about the hinge
            v = moving - origin
            v = (
                v * np.cos(s)
                + np.cross(axis, v) * np.sin(s)
                + np.outer(v @ axis, axis) * (1 - np.cos(s))
            )
            points.extend(origin + v)
        else:
            points.extend(moving + s * axis)
    xy = unit.to_world(np.array(points))[:, :2]
    lo, hi = xy.min(axis=0) - margin, xy.max(axis=0) + margin
    return np.array([[[hi[0], hi[1]], [lo[0], hi[1]], [lo[0], lo[1]], [hi[0], lo[1]]]])


def articulated_targets(layout: Layout) -> list[tuple[str, int]]:
    """(uid, articulation index) of every functional part in the kitchen."""
    return [(p.uid, i) for p in layout.furniture for i in range(len(p.model.articulations))]
