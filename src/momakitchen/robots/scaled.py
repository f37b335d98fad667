"""Arms with scaled links: a built-in arm's joint table with every length multiplied.

A model meant for robots it never saw needs training robots whose reach varies
continuously; real arms come in a few sizes. ``NAME-xS.SS`` (for example ``ur5e-x0.65``)
is robot ``NAME`` with its joint origins, flange offset, link radii and base housing scaled
by ``S`` (in :data:`SCALE_RANGE`), its reach ``S`` times the original's. Joint axes and
limits, the home pose, masses, motor limits, the tool and the mobile base are the
original's: a scaled arm has the same joint space and the same gripper, only longer or
shorter links.

Scaled robots are not listed; the registry (``spec.py``) builds one from its name with
:func:`scaled_model` when it is first asked for it (``get_robot_spec``), in any process,
so a dataset, a worker or a checkpoint can name one like any robot. Only arms built from
joint tables scale (the shipped Panda and xArm6 have meshes, user robots their own URDF).
"""

from __future__ import annotations

import dataclasses
import re

from momakitchen.errors import MomaError
from momakitchen.robots.arms import BuiltArm, JointDef, RobotModel

# Link length factors a scaled arm may have: half to one and a half times the original.
SCALE_RANGE = (0.5, 1.5)
# A scaled link never gets thinner than this (collision radius, metres).
MIN_RADIUS = 0.02

_NAME = re.compile(r"^(?P<base>.+)-x(?P<scale>\d\.\d\d)$")


def scaled_name(base: str, scale: float) -> str:
    """The registry name of ``base`` with links scaled by ``scale`` (two decimals)."""
    return f"{base}-x{scale:.2f}"


def parse_scaled_name(name: str) -> tuple[str, float] | None:
    """``(base, scale)`` if ``name`` is a scaled arm's name (``NAME-xS.SS``), else None."""
    match = _NAME.match(name)
    if match is None:
        return None
    return match["base"], float(match["scale"])


def _times(v: tuple[float, float, float], scale: float) -> tuple[float, float, float]:
    return (scale * v[0], scale * v[1], scale * v[2])


def scaled_arm(arm: BuiltArm, scale: float) -> BuiltArm:
    """``arm`` with every length (joint origins, flange offset, radii, base housing)
    multiplied by ``scale``; angles, axes, limits, masses and motor limits unchanged."""

    def joint(jd: JointDef) -> JointDef:
        return dataclasses.replace(
            jd,
            xyz=_times(jd.xyz, scale),
            radius=max(MIN_RADIUS, scale * jd.radius),
        )

    return dataclasses.replace(
        arm,
        joints=tuple(joint(jd) for jd in arm.joints),
        flange_xyz=_times(arm.flange_xyz, scale),
        base_radius=max(MIN_RADIUS, scale * arm.base_radius),
        base_height=scale * arm.base_height,
    )


def scaled_model(name: str, model: RobotModel, scale: float) -> RobotModel:
    """The model of the scaled arm called ``name``: ``model`` (its base robot's) with links
    scaled by ``scale``; MomaError if the scale is outside :data:`SCALE_RANGE` or the base
    arm is not built from a joint table."""
    lo, hi = SCALE_RANGE
    if not lo <= scale <= hi:
        raise MomaError(f"robot {name!r}: link scale must be in [{lo}, {hi}], got {scale}")
    if not isinstance(model.arm, BuiltArm):
        raise MomaError(
            f"robot {name!r}: only arms built from joint tables scale; "
            f"{name.rsplit('-x', 1)[0]!r} comes from a URDF file"
        )
    return dataclasses.replace(
        model,
        arm=scaled_arm(model.arm, scale),
        source=f"{model.source}; links scaled by {scale:.2f}",
    )
