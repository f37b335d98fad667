"""Settings of an approach run: starts, perception presets, motion and look policy."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from momakitchen.data.manifest import SPLIT_CHOICES
from momakitchen.deploy.fusion import POLICIES, LookPolicy
from momakitchen.errors import MomaError
from momakitchen.models.inference import MC_SAMPLES, PICK_RADIUS
from momakitchen.sim.motion import (
    MotionConfig,
)

STARTS = ("near", "far")
# What the robot knows of the room: ``static`` its walls and fixed furniture (a prior map),
# the obstacles around the target only as its looks see them; ``full`` everything.
MAPS = ("static", "full")
# Named perception presets: a realistic robot's (a D435-like stereo camera, a segmenter's
# masks shifted 5 px, the camera 1 cm high and rolled 1 deg) and a perfect one; any
# corruption name of ``momakitchen robustness --list`` works too.
PERCEPTION = {"realistic": "combined-d435", "ideal": "clean"}
# Final-stop errors of the sweep: (cm, deg) standard deviations.
# 0-10 cm (a docking-grade controller), then two coarser stops: where success halves.
STOP_SWEEP = ((0.0, 0.0), (3.0, 2.0), (6.0, 4.0), (10.0, 6.0), (20.0, 10.0), (30.0, 15.0))


def perception_corruption(name: str) -> str:
    """The corruption of a perception preset name (or a corruption name itself)."""
    from momakitchen.perception.sensors import CORRUPTIONS

    if name in PERCEPTION:
        return PERCEPTION[name]
    if name not in CORRUPTIONS:
        raise MomaError(
            f"unknown perception preset {name!r}; presets: {', '.join(PERCEPTION)} or a "
            "corruption of `momakitchen robustness --list`"
        )
    return name


@dataclass(frozen=True)
class ApproachConfig:
    """Settings of an approach run.

    Attributes:
        starts: ``near`` and/or ``far``.
        policies: look policies of the model methods (:data:`POLICIES`).
        perception: a :data:`PERCEPTION` preset or a corruption name.
        seed: seeds the near start (as ``msr --seed``), motion and perception errors and
            the random baseline; the same for every method.
        split, max_configs: which configurations.
        part: ``(k, n)``: only the scenes ``k-1, k-1+n, ...`` of the split's scenes in
            order (part k of n, to run one split in several processes or on several
            machines; ``approach --merge`` joins the parts); (1, 1): all.
        far_range: distance range (m) of far starts; ``far_angle``: deg either side of
            the direction the target faces.
        look: the look policy's thresholds (its ``kind`` is set per policy).
        mc_samples: MC-dropout passes per look (the ``uncertain`` policy reads them).
        pick_radius: goals ranked by the fused map averaged over this radius (m).
        stop_sweep: run the final trial again at these stop errors ((cm, deg) pairs) from
            the same pre-stop pose; () for none.
        motion: driving speed, drift and stop error.
        map: what the robot knows of the room at the start (:data:`MAPS`).
        obstacle_min_points: with a static map, a look marks a costmap cell only where at
            least this many of its points above the floor fall in it (1: every point, as
            a bare obstacle layer does; more: a stray depth point marks nothing).
    """

    starts: tuple[str, ...] = ("far",)
    policies: tuple[str, ...] = POLICIES
    perception: str = "realistic"
    seed: int = 0
    split: str = "test"
    max_configs: int = 0
    part: tuple[int, int] = (1, 1)
    far_range: tuple[float, float] = (3.8, 6.0)
    far_angle: float = 45.0
    look: LookPolicy = field(default_factory=LookPolicy)
    mc_samples: int = MC_SAMPLES
    pick_radius: float = PICK_RADIUS
    stop_sweep: tuple[tuple[float, float], ...] = ()
    motion: MotionConfig = field(default_factory=MotionConfig)
    map: str = "static"
    obstacle_min_points: int = 1

    def __post_init__(self) -> None:
        for name, values, allowed in (
            ("start", self.starts, STARTS),
            ("policy", self.policies, POLICIES),
        ):
            if not values:
                raise MomaError(f"no {name} given; choose from {', '.join(allowed)}")
            for v in values:
                if v not in allowed:
                    raise MomaError(f"unknown {name} {v!r}; choose from {', '.join(allowed)}")
            if len(set(values)) != len(values):
                raise MomaError(f"{name} named twice: {list(values)}")
        perception_corruption(self.perception)
        if self.map not in MAPS:
            raise MomaError(f"unknown map {self.map!r}; choose from {', '.join(MAPS)}")
        if not (
            isinstance(self.obstacle_min_points, int) and 1 <= self.obstacle_min_points <= 1000
        ):
            raise MomaError(
                "obstacle_min_points must be an integer in [1, 1000], got "
                f"{self.obstacle_min_points!r}"
            )
        if self.seed < 0 or self.max_configs < 0:
            raise MomaError("seed and max_configs must be >= 0")
        k, n = self.part
        if not 1 <= k <= n:
            raise MomaError(f"part must be K/N with 1 <= K <= N, got {k}/{n}")
        if self.split not in SPLIT_CHOICES:
            raise MomaError(f"split must be one of {SPLIT_CHOICES}, got {self.split!r}")
        lo, hi = self.far_range
        if not (math.isfinite(lo) and math.isfinite(hi) and 1.0 <= lo <= hi <= 15.0):
            raise MomaError(f"far_range must be 1 <= lo <= hi <= 15 m, got {self.far_range}")
        if not 0.0 < self.far_angle <= 90.0:
            raise MomaError(f"far_angle must be in (0, 90] deg, got {self.far_angle}")
        if not 0 <= self.mc_samples <= 64:
            raise MomaError(f"mc_samples must be in [0, 64], got {self.mc_samples}")
        if not 0.0 <= self.pick_radius <= 1.0:
            raise MomaError(f"pick_radius must be in [0, 1] m, got {self.pick_radius}")
        for cm, deg in self.stop_sweep:
            if not (0 <= cm <= 50 and 0 <= deg <= 45):
                raise MomaError(
                    f"stop errors must be in [0, 50] cm and [0, 45] deg, got {cm}, {deg}"
                )

    def to_dict(self) -> dict[str, Any]:
        from dataclasses import asdict

        out = asdict(self)
        out["perception_corruption"] = perception_corruption(self.perception)
        if self.obstacle_min_points == 1:
            # Runs with the default stay equal to runs made before the setting existed, so
            # they merge and pool with them.
            del out["obstacle_min_points"]
        return out
