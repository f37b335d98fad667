"""The TF tree of a bag: static edges from ``/tf_static``, time series of dynamic ones
from ``/tf``, and the transform between two frames at a stamp (composed along the tree,
moving edges interpolated as tf2 does)."""

from __future__ import annotations

import math
from collections import defaultdict, deque
from collections.abc import Sequence
from typing import Any

import numpy as np

from momakitchen.errors import MomaError

# Seconds a /tf sample may lie outside the span of a dynamic transform's samples and still
# be used (tf2 itself never extrapolates; a robot state publisher at 30 Hz leaves gaps of
# 33 ms before the first and after the last sample).
TF_EDGE_TOLERANCE = 0.05


def transform_matrix(
    translation: Sequence[float] | np.ndarray, quaternion_xyzw: Sequence[float] | np.ndarray
) -> np.ndarray:
    """(4, 4) from a translation and an ``x, y, z, w`` quaternion (normalised here)."""
    from scipy.spatial.transform import Rotation

    q = np.asarray(quaternion_xyzw, np.float64)
    if not (np.isfinite(q).all() and np.linalg.norm(q) > 1e-9):
        raise MomaError(f"TF rotation {q.tolist()} is not a quaternion")
    _check_translation(translation, "TF translation")
    m = np.eye(4)
    m[:3, :3] = Rotation.from_quat(q / np.linalg.norm(q)).as_matrix()
    m[:3, 3] = translation
    return m


def _check_translation(translation: Sequence[float] | np.ndarray, what: str) -> None:
    """MomaError naming the first non-finite coordinate of ``translation``: checked before
    any transform is composed, so that an infinity is named where it is (composing spreads
    it, as NaN, to the other coordinates) and NumPy never warns."""
    for axis, value in zip("xyz", np.asarray(translation, np.float64).tolist(), strict=True):
        if not math.isfinite(value):
            raise MomaError(f"{what} has {axis} = {value}: not a finite number")


class TransformBuffer:
    """The TF tree of a bag: static edges and time series of dynamic ones.

    An edge ``parent -> child`` holds ``T_parent_child`` (child coordinates to parent
    coordinates), as ``geometry_msgs/TransformStamped`` does. :meth:`lookup` composes the
    edges of the path between two frames at one time, interpolating dynamic edges (linear
    translation, spherical rotation) as tf2 does.
    """

    def __init__(self) -> None:
        self.static: dict[tuple[str, str], np.ndarray] = {}
        self._dynamic: dict[tuple[str, str], list[tuple[int, np.ndarray, np.ndarray]]] = (
            defaultdict(list)
        )
        self._stamps: dict[tuple[str, str], np.ndarray] = {}
        self._sorted = True

    def add(self, parent: str, child: str, stamp_ns: int, transform: Any, static: bool) -> None:
        """Add a ``geometry_msgs/Transform`` message's edge."""
        t, r = transform.translation, transform.rotation
        parent, child = parent.lstrip("/"), child.lstrip("/")
        if static:
            try:
                m = transform_matrix((t.x, t.y, t.z), (r.x, r.y, r.z, r.w))
            except MomaError as exc:
                raise MomaError(f"/tf_static {parent!r} -> {child!r}: {exc}") from None
            self.static[(parent, child)] = m
        else:
            q = np.array([r.x, r.y, r.z, r.w], np.float64)
            self._dynamic[(parent, child)].append((stamp_ns, np.array([t.x, t.y, t.z]), q))
            self._sorted = False

    def frames(self) -> list[str]:
        return sorted({f for edge in [*self.static, *self._dynamic] for f in edge})

    def _neighbours(self) -> dict[str, list[tuple[str, tuple[str, str], bool]]]:
        graph: dict[str, list[tuple[str, tuple[str, str], bool]]] = defaultdict(list)
        for edge in [*self.static, *self._dynamic]:
            graph[edge[0]].append((edge[1], edge, True))  # parent -> child: T as stored
            graph[edge[1]].append((edge[0], edge, False))  # child -> parent: inverted
        return graph

    def _edge(self, edge: tuple[str, str], stamp_ns: int) -> np.ndarray:
        if edge not in self._dynamic:
            return self.static[edge]
        from scipy.spatial.transform import Rotation, Slerp

        if not self._sorted:
            for key, samples in self._dynamic.items():
                samples.sort(key=lambda s: s[0])
                self._stamps[key] = np.array([s[0] for s in samples], np.int64)
            self._sorted = True
        samples, stamps = self._dynamic[edge], self._stamps[edge]
        tol = int(TF_EDGE_TOLERANCE * 1e9)
        if stamp_ns < stamps[0] - tol or stamp_ns > stamps[-1] + tol:
            raise MomaError(
                f"no /tf transform {edge[0]!r} -> {edge[1]!r} at t={stamp_ns * 1e-9:.3f} s: "
                f"the bag has it from {stamps[0] * 1e-9:.3f} to {stamps[-1] * 1e-9:.3f} s"
            )
        i = int(np.searchsorted(stamps, stamp_ns))
        if i == 0 or i == len(stamps):
            t, trans, quat = samples[0 if i == 0 else -1]
            _check_translation(
                trans, f"the /tf transform {edge[0]!r} -> {edge[1]!r} at t={t * 1e-9:.3f} s"
            )
            return transform_matrix(trans, quat)
        (t0, p0, q0), (t1, p1, q1) = samples[i - 1], samples[i]
        a = (stamp_ns - t0) / (t1 - t0) if t1 > t0 else 0.0
        for t, p, q in ((t0, p0, q0), (t1, p1, q1)):
            if not (np.isfinite(q).all() and np.linalg.norm(q) > 1e-9):
                raise MomaError(f"TF rotation {q.tolist()} of {edge[0]!r} -> {edge[1]!r}")
            _check_translation(
                p, f"the /tf transform {edge[0]!r} -> {edge[1]!r} at t={t * 1e-9:.3f} s"
            )
        rot = Slerp([0.0, 1.0], Rotation.from_quat([q0, q1]))([a])
        m = np.eye(4)
        m[:3, :3] = rot.as_matrix()[0]
        m[:3, 3] = (1 - a) * p0 + a * p1
        return m

    def lookup(
        self, target: str, source: str, stamp_ns: int, source_role: str = "the camera frame"
    ) -> np.ndarray:
        """(4, 4) ``T_target_source``: ``source`` coordinates to ``target`` coordinates;
        ``source_role`` names ``source`` in the error when no path joins them."""
        target, source = target.lstrip("/"), source.lstrip("/")
        if target == source:
            return np.eye(4)
        graph = self._neighbours()
        previous: dict[str, tuple[str, tuple[str, str], bool]] = {}
        queue, seen = deque([source]), {source}
        while queue and target not in seen:
            frame = queue.popleft()
            for nxt, edge, forward in graph.get(frame, []):
                if nxt not in seen:
                    seen.add(nxt)
                    previous[nxt] = (frame, edge, forward)
                    queue.append(nxt)
        if target not in seen:
            known = self.frames()
            raise MomaError(
                f"no TF path from {source_role} {source!r} to {target!r}; the bag's TF "
                f"frames are {known or 'none'}"
                + (
                    f" (connected to {source!r}: {sorted(seen - {source})})"
                    if len(seen) > 1
                    else ""
                )
            )
        # Walk back from the target: T_target_source = T_target_a @ T_a_b @ ... @ T_z_source.
        m, frame = np.eye(4), target
        while frame != source:
            prev, edge, forward = previous[frame]
            t = self._edge(edge, stamp_ns)  # T_parent_child
            # forward: prev is the parent, frame the child; we need T_frame_prev.
            m = m @ (np.linalg.inv(t) if forward else t)
            frame = prev
        return m


def planar_pose(transform: np.ndarray) -> tuple[float, float, float]:
    """``(x, y, yaw)`` of a (4, 4) ``T_odom_base``: the base's position on the floor and its
    heading about z (a base on a level floor has no roll or pitch to keep)."""
    m = np.asarray(transform, np.float64)
    return float(m[0, 3]), float(m[1, 3]), math.atan2(float(m[1, 0]), float(m[0, 0]))
