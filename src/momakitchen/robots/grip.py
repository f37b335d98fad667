"""Grippers of another strength: a robot with its fingers' closing force changed.

``NAME-fN`` (for example ``realman-f40``, or ``realman-x0.72-f40`` for a scaled arm) is
robot ``NAME`` with fingers that close with ``N`` newtons each (in :data:`FORCE_RANGE`),
everything else the original's. The force decides which targets can be opened at all: a
fridge door's seal holds against 40 N fingers that slip off its handle where 80 N ones pull
it open (docs/ROBOTS.md, "Grip force"). The robot descriptor carries it (version 2), and
training robots whose forces vary are how a model learns what it changes.

Like scaled arms, these robots are not listed; the registry (``spec.py``) builds one from
its name with :func:`grip_model` the first time it is asked for it, in any process. Only
parallel grippers have a finger force.
"""

from __future__ import annotations

import dataclasses
import re

from momakitchen.errors import MomaError
from momakitchen.robots.arms import ParallelGripper, RobotModel, UserTool

# Closing forces per finger a gripper variant may have, N (small electric grippers give
# ~20 N, industrial ones 100-200 N).
FORCE_RANGE = (10.0, 200.0)

_NAME = re.compile(r"^(?P<base>.+)-f(?P<force>\d{2,3})$")


def grip_name(base: str, force: float) -> str:
    """The registry name of ``base`` with ``force`` N per finger (whole newtons)."""
    return f"{base}-f{round(force)}"


def parse_grip_name(name: str) -> tuple[str, float] | None:
    """``(base, force)`` if ``name`` is a gripper variant's name (``NAME-fN``), else None."""
    match = _NAME.match(name)
    if match is None:
        return None
    return match["base"], float(match["force"])


def grip_model(name: str, model: RobotModel, force: float) -> RobotModel:
    """The model of the gripper variant called ``name``: ``model`` (its base robot's) with
    ``force`` N per finger; MomaError if the force is outside :data:`FORCE_RANGE` or the
    base robot's tool is not a parallel gripper."""
    lo, hi = FORCE_RANGE
    if not lo <= force <= hi:
        raise MomaError(
            f"robot {name!r}: finger force must be in [{lo:g}, {hi:g}] N, got {force:g}"
        )
    tool = model.end_effector
    if model.tool_kind != "parallel_gripper" or not isinstance(tool, ParallelGripper | UserTool):
        base = name.rsplit("-f", 1)[0]
        raise MomaError(
            f"robot {name!r}: only parallel grippers have a finger force; "
            f"{base!r} has a suction cup"
        )
    return dataclasses.replace(
        model,
        end_effector=dataclasses.replace(tool, finger_force=float(force)),
        source=f"{model.source}; fingers closing with {force:g} N",
    )
