"""Fusing the maps of successive looks while the base drives (the robot's and the
simulated approach's one code path).

A robot that drives toward its target takes a frame now and then; each frame's
:class:`~momakitchen.models.inference.Prediction` lies in the base frame at that moment.
:class:`MapFusion` moves every look's floor points into the odometry frame with the
base pose odometry reported for the frame, bins them into square cells and keeps, per
cell, a weighted mean of the affordance and of its MC-dropout uncertainty. A point seen
from closer weighs more (weight ``1 / max(r, r_min)**2`` for a point ``r`` metres from the
base at the look): depth noise grows with range and the model was trained on views of
1.5-3.8 m, so a later, closer look overrules an earlier, farther one where both saw the
floor, and cells only the far look saw keep its values.

The goal is the best fused cell, ranked as ``predict`` ranks poses (the map averaged
over ``pick_radius``, :func:`momakitchen.models.inference.select_points`), among those
the caller says the base can reach; the base faces the target from it. Whether to look
again is a :class:`LookPolicy`'s question, the same for the robot and the simulated
approach: :meth:`LookPolicy.look_again` at a look, :meth:`LookPolicy.next_look` when a
path to the goal is planned.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from momakitchen.errors import MomaError
from momakitchen.frames import base_to_world_xy

POLICIES = ("single", "relook", "uncertain")


@dataclass(frozen=True)
class LookPolicy:
    """When a driving robot looks again.

    Attributes:
        kind: ``single`` (one look, at the start), ``relook`` (look again once the base
            is within ``relook_distance`` of the goal) or ``uncertain`` (look again while
            the MC-dropout uncertainty at the goal exceeds ``max_uncertainty`` or the
            target was farther than ``trusted_distance`` at the last look).
        relook_distance: m (``relook``).
        max_uncertainty: MC-dropout standard deviation at the goal (``uncertain``).
        trusted_distance: target distance (m) beyond which a look is not trusted
            (``uncertain``; the training views reach hypot(3.8, 1.5) = 4.08 m).
        max_looks: the most looks per approach, the first included.
    """

    kind: str = "relook"
    relook_distance: float = 1.5
    max_uncertainty: float = 0.10
    trusted_distance: float = 3.5
    max_looks: int = 3

    def __post_init__(self) -> None:
        if self.kind not in POLICIES:
            raise MomaError(f"unknown policy {self.kind!r}; policies: {', '.join(POLICIES)}")
        for name in ("relook_distance", "trusted_distance"):
            v = getattr(self, name)
            if not (math.isfinite(v) and 0.0 < v <= 10.0):
                raise MomaError(f"LookPolicy.{name} must be in (0, 10] m, got {v!r}")
        if not (math.isfinite(self.max_uncertainty) and 0.0 <= self.max_uncertainty <= 1.0):
            raise MomaError(
                f"LookPolicy.max_uncertainty must be in [0, 1], got {self.max_uncertainty!r}"
            )
        if not 1 <= self.max_looks <= 10:
            raise MomaError(f"LookPolicy.max_looks must be in [1, 10], got {self.max_looks!r}")

    def can_look(self, looks: int) -> bool:
        """Whether another look is allowed after ``looks`` (failed ones included)."""
        return self.kind != "single" and looks < self.max_looks

    def look_again(
        self, fusion: MapFusion, base_xy: Sequence[float], goal: FusedGoal | None
    ) -> bool:
        """Whether to take another look with the base at ``base_xy`` (odometry frame)
        heading for ``goal`` (None: no goal yet, so look again if allowed), given the
        looks ``fusion`` holds."""
        if fusion.looks >= self.max_looks or self.kind == "single":
            return False
        if goal is None:
            return True
        dist = float(np.hypot(goal.pose[0] - base_xy[0], goal.pose[1] - base_xy[1]))
        if self.kind == "relook":
            # One more look once close, unless the last look was already taken that close.
            return fusion.looks < 2 and dist <= self.relook_distance
        return (
            goal.uncertainty > self.max_uncertainty
            or fusion.last_target_distance > self.trusted_distance
        )

    def next_look(
        self,
        looks: int,
        fusion: MapFusion,
        base_xy: Sequence[float],
        goal: FusedGoal,
        remaining: float,
    ) -> float:
        """Metres to drive along a planned path of ``remaining`` m to ``goal`` before the
        next look (inf: drive to the goal), after ``looks`` looks.

        ``relook`` stops once, ``relook_distance`` before the goal; ``uncertain`` stops
        halfway (at least 0.5 m on) while :meth:`look_again` holds and over a metre is
        left, so that the next look is closer to where the goal is."""
        if not self.can_look(looks):
            return math.inf
        if self.kind == "relook":
            if looks < 2 and remaining > self.relook_distance:
                return remaining - self.relook_distance
        elif self.look_again(fusion, base_xy, goal) and remaining > 1.0:
            return max(0.5, 0.5 * remaining)
        return math.inf


@dataclass(frozen=True)
class FusedGoal:
    """The fused map's goal: ``pose`` (x, y, yaw) in the odometry frame facing the
    target, the fused ``affordance`` and ``uncertainty`` of its cell."""

    pose: tuple[float, float, float]
    affordance: float
    uncertainty: float


@dataclass
class MapFusion:
    """The fused affordance map of a robot's looks, in its odometry frame.

    Attributes:
        cell: side of the square cells (m).
        min_range: ranges below this weigh as this (m), so that a point at the robot's
            feet does not outweigh everything else.
    """

    cell: float = 0.05
    min_range: float = 0.5
    _sum: dict[tuple[int, int], np.ndarray] = field(default_factory=dict, repr=False)
    looks: int = 0
    last_target_distance: float = math.inf
    target_xy: np.ndarray | None = None

    def __post_init__(self) -> None:
        if not (math.isfinite(self.cell) and 0.005 <= self.cell <= 0.5):
            raise MomaError(f"MapFusion.cell must be in [0.005, 0.5] m, got {self.cell!r}")
        if not (math.isfinite(self.min_range) and 0.05 <= self.min_range <= 5.0):
            raise MomaError(f"MapFusion.min_range must be in [0.05, 5] m, got {self.min_range!r}")

    def add(self, prediction: Any, odom_pose: Sequence[float]) -> None:
        """Fuse one look: ``prediction`` (a :class:`Prediction`, base frame at the look)
        taken with the base at ``odom_pose`` = (x, y, yaw) in the odometry frame."""
        pose = np.asarray(odom_pose, np.float64).reshape(-1)
        if pose.shape != (3,) or not np.isfinite(pose).all():
            raise MomaError(f"odom_pose must be 3 finite numbers (x, y, yaw), got {odom_pose!r}")
        xy = np.asarray(prediction.floor_xyz, np.float64)[:, :2]
        value = np.asarray(prediction.affordance, np.float64)
        std = np.asarray(prediction.uncertainty, np.float64)
        if not (np.isfinite(value).all() and np.isfinite(std).all()):
            raise MomaError("a look's affordance or uncertainty is not finite")
        weight = 1.0 / np.maximum(np.hypot(xy[:, 0], xy[:, 1]), self.min_range) ** 2
        odom = base_to_world_xy(xy, tuple(pose))
        keys = np.floor(odom / self.cell).astype(np.int64)
        # One row per cell: the sums of w, w*value, w*std over this look's points.
        uniq, inverse = np.unique(keys, axis=0, return_inverse=True)
        inverse = inverse.reshape(-1)
        sums = np.stack(
            [np.bincount(inverse, w, len(uniq)) for w in (weight, weight * value, weight * std)],
            axis=1,
        )
        for key, row in zip(map(tuple, uniq.tolist()), sums, strict=True):
            if key in self._sum:
                self._sum[key] = self._sum[key] + row
            else:
                self._sum[key] = row
        target = np.asarray(prediction.target_xyz, np.float64)[:2]
        self.target_xy = base_to_world_xy(target[None], tuple(pose))[0]
        self.last_target_distance = float(np.hypot(*target))
        self.looks += 1

    def fused(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Cell centres (M, 2) in the odometry frame, fused affordance (M,) and
        uncertainty (M,); cells in a fixed (sorted) order."""
        if not self._sum:
            return np.zeros((0, 2)), np.zeros(0), np.zeros(0)
        keys = sorted(self._sum)
        sums = np.stack([self._sum[k] for k in keys])
        centres = (np.asarray(keys, np.float64) + 0.5) * self.cell
        return centres, sums[:, 1] / sums[:, 0], sums[:, 2] / sums[:, 0]

    def goal(
        self,
        reachable: Callable[[float, float], bool] | None = None,
        pick_radius: float = 0.0,
    ) -> FusedGoal | None:
        """The best fused cell the base can reach (``reachable(x, y)`` in the odometry
        frame; None: every cell), facing the fused target; None when no cell qualifies."""
        from momakitchen.models.inference import select_points

        xy, value, std = self.fused()
        if not len(xy) or self.target_xy is None:
            return None
        accept = None if reachable is None else (lambda i: reachable(*xy[i]))
        chosen = select_points(xy, value, 1, 0.0, accept, pick_radius)
        if not chosen:
            return None
        i = chosen[0]
        d = self.target_xy - xy[i]
        yaw = math.atan2(d[1], d[0])
        return FusedGoal((float(xy[i, 0]), float(xy[i, 1]), yaw), float(value[i]), float(std[i]))
