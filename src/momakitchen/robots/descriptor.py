"""The robot as numbers for the model (the robot descriptor), from its registered spec.

The layouts, their versions and :func:`~momakitchen.robots.spec.descriptor_values` (a robot
given by its numbers) are in ``spec.py``; what needs the robot's URDF (where its shoulder
stands, ``shoulder.py``) is here, above both.
"""

from __future__ import annotations

import numpy as np

from momakitchen.errors import MomaError
from momakitchen.robots.shoulder import shoulder_geometry
from momakitchen.robots.spec import (
    DESCRIPTOR_VERSION,
    RobotSpec,
    descriptor_dim,
    descriptor_values,
    finger_force,
    get_robot_spec,
)


def robot_descriptor(spec: RobotSpec, mount_height: float | None = None) -> tuple[float, ...]:
    """The robot as numbers for the model, in the order of ``DESCRIPTOR_NAMES`` (length
    ``DESCRIPTOR_DIM``).

    The first two entries are the paper's descriptor ``[reach, mount height]``; the mount
    height is ``mount_height`` where given (a configuration's sampled mount), else the
    robot's own.
    """
    mount = spec.mount_height if mount_height is None else mount_height
    suction = spec.end_effector == "suction"
    rise, offset = shoulder_geometry(spec)
    return descriptor_values(spec.reach, mount, spec.dof, suction, finger_force(spec), rise, offset)


def upgrade_descriptor(descriptor: np.ndarray, version: int, robot: str) -> np.ndarray:
    """A version-``version`` descriptor of robot ``robot`` (a NumPy array of shape
    ``(descriptor_dim(version),)``) as a current one (``(DESCRIPTOR_DIM,)``, same dtype):
    the columns added since are the robot's (its spec by name; a user robot must be
    registered) at the mount height the descriptor holds. Returned as given when already
    current."""
    d = np.asarray(descriptor)
    if version == DESCRIPTOR_VERSION:
        return d
    if d.shape != (descriptor_dim(version),):
        raise MomaError(
            f"a version-{version} robot descriptor has {descriptor_dim(version)} values, "
            f"got shape {d.shape}"
        )
    # The stored mount (float32) as written: mounts are drawn to the millimetre.
    mount = round(float(d[1]), 6)
    full = np.asarray(robot_descriptor(get_robot_spec(robot), mount), d.dtype)
    return np.concatenate([d, full[d.shape[0] :]])
