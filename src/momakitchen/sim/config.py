"""Trial and labelling settings, and the trial stages: plain data, no simulator.

The dataset reader and the generation config read these without loading PyBullet.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

from momakitchen.errors import MomaError


class Stage(IntEnum):
    """Outcome of a trial: success or the stage that failed."""

    SUCCESS = 0
    BASE_COLLISION = 1
    OUT_OF_REACH = 2
    IK_FAILED = 3
    ARM_COLLISION = 4
    EXECUTION_FAILED = 5


STAGE_NAMES = tuple(s.name.lower() for s in Stage)


@dataclass(frozen=True)
class TrialConfig:
    """Parameters of a trial (distances in metres, durations in seconds).

    Attributes:
        pregrasp_offset: distance of the pre-grasp pose from the grasp point along the
            surface normal.
        lift_height: how far grippers and suction lift a rigid object.
        min_lift: a rigid trial succeeds if the object rose at least this much...
        hold_seconds: ...and is still held after this long.
        open_angle_deg, open_distance: an articulated trial succeeds if the joint opened
            at least this much (revolute / prismatic).
        pull_angle_deg, pull_distance: how far the arm tries to open the part: a
            margin beyond the success threshold (pulling farther costs physics and
            decides nothing).
        max_grasp_depth: a gripper's TCP (the centre between the finger pads) goes this
            far behind the grasp surface at most, and never deeper than half the grasp
            width: to the axis of a bottle, around a handle bar, over the top of a fruit.
        max_grasp_candidates: rigid targets offer several grasp frames; this many, the
            best aligned with the robot first, are tried.
        ik_restarts: IK starts beyond the home configuration for the pre-grasp pose (the
            robot's library configurations nearest the pose); each distinct solution is
            checked for collisions until one is free.
        approach_tilt_deg: where the approach along the surface normal finds no plan,
            grippers also approach turned this far about the closing axis (the pads
            still hold the part), from above first; 0 turns this off.
        solver_iterations: PyBullet constraint-solver iterations per step during trials
            (PyBullet's default is 50; 30 gives the same outcomes on our scenes, faster).
    """

    pregrasp_offset: float = 0.08
    lift_height: float = 0.10
    min_lift: float = 0.05
    hold_seconds: float = 1.0
    open_angle_deg: float = 20.0
    open_distance: float = 0.10
    pull_angle_deg: float = 26.0
    pull_distance: float = 0.125
    max_grasp_depth: float = 0.03
    max_grasp_candidates: int = 3
    ik_restarts: int = 5
    approach_tilt_deg: float = 20.0
    solver_iterations: int = 30

    def __post_init__(self) -> None:
        positive = (
            "pregrasp_offset",
            "lift_height",
            "min_lift",
            "open_angle_deg",
            "open_distance",
            "pull_angle_deg",
            "pull_distance",
        )
        for name in positive:
            if not getattr(self, name) > 0:
                raise MomaError(f"TrialConfig.{name} must be > 0, got {getattr(self, name)}")
        if self.min_lift > self.lift_height:
            raise MomaError(
                f"TrialConfig.min_lift ({self.min_lift}) exceeds lift_height ({self.lift_height})"
            )
        if self.pull_angle_deg < self.open_angle_deg or self.pull_distance < self.open_distance:
            raise MomaError("TrialConfig: the commanded pull must exceed the success threshold")
        if not 0 <= self.hold_seconds <= 10:
            raise MomaError(f"TrialConfig.hold_seconds must be in [0, 10], got {self.hold_seconds}")
        if not 0 <= self.approach_tilt_deg <= 60:
            raise MomaError(
                f"TrialConfig.approach_tilt_deg must be in [0, 60], got {self.approach_tilt_deg}"
            )
        if not 5 <= self.solver_iterations <= 500:
            raise MomaError(
                f"TrialConfig.solver_iterations must be in [5, 500], got {self.solver_iterations}"
            )
        if not 1 <= self.max_grasp_candidates <= 10:
            raise MomaError(
                "TrialConfig.max_grasp_candidates must be in [1, 10], got "
                f"{self.max_grasp_candidates}"
            )


@dataclass(frozen=True)
class DenseMapConfig:
    """Dense-map interpolation (metres).

    Attributes:
        theta: association threshold: trial positions farther than this from a floor
            point do not contribute to it (default 1.5 x the 10 cm grid spacing).
        k: number of nearest associated trial positions averaged.
        sigma: Gaussian weighting scale.
    """

    theta: float = 0.15
    k: int = 8
    sigma: float = 0.07

    def __post_init__(self) -> None:
        if not 0.0 < self.theta <= 2.0:
            raise MomaError(f"DenseMapConfig.theta must be in (0, 2] m, got {self.theta}")
        if not 1 <= self.k <= 64:
            raise MomaError(f"DenseMapConfig.k must be in [1, 64], got {self.k}")
        if not 0.0 < self.sigma <= 2.0:
            raise MomaError(f"DenseMapConfig.sigma must be in (0, 2] m, got {self.sigma}")
