"""A mobile manipulator in a PyBullet client: the one object to call.

``Robot`` is a facade over its concerns: the body (loading, joint indexing, placement, FK)
in ``body.py``, IK in ``ik.py``, reach and workspace in ``reach.py``, collisions in
``collisions.py``, and the gripper or suction cup in ``tools.py`` (``robot.tool``).

Every PyBullet call passes the robot's ``client_id``, so robots in several independent
DIRECT clients of one process do not interfere. The base is fixed (teleported, not
driven): last-mile navigation only needs the stopping pose.

Conventions: positions in metres (world frame), quaternions ``(x, y, z, w)`` as PyBullet
uses them, joint vectors of shape ``(dof,)`` in the order of :attr:`Robot.joint_names`.
The TCP frame's z axis is the approach direction; gripper fingers close along its y axis.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator, Sequence

import numpy as np
from numpy.typing import ArrayLike

from momakitchen.bullet import connect_direct, p
from momakitchen.errors import MomaError
from momakitchen.robots import collisions, ik, reach
from momakitchen.robots.body import RobotBody, variant_key
from momakitchen.robots.collisions import Contact
from momakitchen.robots.ik import IKResult
from momakitchen.robots.spec import get_robot_spec
from momakitchen.robots.tools import ParallelGripperTool, SuctionTool, Tool, make_tool
from momakitchen.robots.urdf import mounted

_WARMING: set[str] = set()


def _warm_caches(name: str, mount_height: float | None = None) -> None:
    """Compute a robot's per-process caches (workspace, self-collision pairs, IK seed
    library) once, in a scratch client of their own.

    Computing them lazily inside a world would teleport its joints thousands of times in
    the middle of whatever that world was doing, and PyBullet's results depend, in the
    last bits, on such history: with the caches warmed apart, a world's results depend
    only on what is done in it. The workspace and the seed library are the same at every
    mount height (measured at the robot's own); the self-collision pairs, which include
    the base, are computed for each height, in a scratch client of their own too.
    """
    if name in _WARMING:
        return
    key = variant_key(name, mount_height)
    if not (
        name in reach.WORKSPACE_CACHE
        and name in collisions.SELF_PAIRS_CACHE
        and name in ik.SEED_LIBRARY
    ):
        _WARMING.add(name)
        client = connect_direct()
        try:
            robot = Robot(client, name)
            robot.workspace()
            robot._self_pairs()
            ik.SEED_LIBRARY.setdefault(name, ik.build_seed_library(robot))
        finally:
            p.disconnect(client)
            _WARMING.discard(name)
    if key not in collisions.SELF_PAIRS_CACHE:
        _WARMING.add(name)
        client = connect_direct()
        try:
            Robot(client, name, mount_height=mount_height)._self_pairs()
        finally:
            p.disconnect(client)
            _WARMING.discard(name)


def forget_caches(name: str) -> None:
    """Drop the per-process caches of robot ``name`` (when a user robot is unregistered),
    at every mount height."""
    reach.WORKSPACE_CACHE.pop(name, None)
    for key in [k for k in collisions.SELF_PAIRS_CACHE if k == name or k.startswith(f"{name}@")]:
        del collisions.SELF_PAIRS_CACHE[key]
    ik.SEED_LIBRARY.pop(name, None)


def quaternion_angle(q1: ArrayLike, q2: ArrayLike) -> float:
    """Angle in radians of the rotation between two unit quaternions ``(x, y, z, w)``."""
    dot = abs(float(np.dot(np.asarray(q1, float), np.asarray(q2, float))))
    return 2.0 * math.acos(min(1.0, dot))


class Robot(RobotBody):
    """One registered robot loaded into a PyBullet client, with its tool (``robot.tool``).

    Args:
        client_id: PyBullet physics client (e.g. from ``p.connect(p.DIRECT)``).
        name: registered robot name (``momakitchen.robots.ROBOTS``).
        base: initial base pose ``(x, y, yaw)``.
        mount_height: arm mount height in metres (default: the robot's own); any height of
            :data:`~momakitchen.robots.spec.MOUNT_RANGE`, else MomaError naming it.
    """

    def __init__(
        self,
        client_id: int,
        name: str,
        base: Sequence[float] = (0.0, 0.0, 0.0),
        *,
        mount_height: float | None = None,
    ):
        mounted(get_robot_spec(name), mount_height)  # bad names and heights fail first
        _warm_caches(name, mount_height)
        super().__init__(client_id, name, mount_height)
        self.tool: Tool = make_tool(self)
        self.place_base(*base)
        self.set_joint_positions(self.home)
        if isinstance(self.tool, ParallelGripperTool):
            for j in self.tool.finger_joints:
                p.changeDynamics(
                    self.body,
                    j,
                    lateralFriction=1.5,
                    spinningFriction=0.01,
                    physicsClientId=self.client,
                )
            self.tool.set_opening(self.tool.max_opening)

    # ---------------------------------------------------------------- IK (ik.py)
    def solve_ik(
        self,
        position: ArrayLike,
        orientation: ArrayLike | None = None,
        *,
        seed: ArrayLike | None = None,
        pos_tol: float = 0.005,
        ori_tol: float = math.radians(2.0),
        iterations: int = 40,
        restarts: int = 8,
        rng: np.random.Generator | None = None,
    ) -> IKResult:
        """Joint positions placing the TCP at ``position`` (and ``orientation``); see
        :func:`momakitchen.robots.ik.solve_ik`. The arm is left at the answer."""
        return ik.solve_ik(
            self,
            position,
            orientation,
            seed=seed,
            pos_tol=pos_tol,
            ori_tol=ori_tol,
            iterations=iterations,
            restarts=restarts,
            rng=rng,
        )

    def ik_solutions(
        self, position: ArrayLike, orientation: ArrayLike | None, *, starts: int = 6
    ) -> Iterator[IKResult]:
        """Distinct converged IK solutions of one pose, from home then from library
        configurations (see :func:`momakitchen.robots.ik.ik_solutions`)."""
        return ik.ik_solutions(self, position, orientation, starts=starts)

    def plan_line(
        self, position: ArrayLike, orientation: ArrayLike | None, n: int = 10
    ) -> list[np.ndarray] | None:
        """IK waypoints (each ``(dof,)``) moving the TCP on a straight line to a pose, or
        None if any fails; the joint state is left untouched."""
        return ik.plan_line(self, position, orientation, n)

    # ---------------------------------------------------------------- reach (reach.py)
    def workspace(self) -> tuple[float, float]:
        """``(max flange distance, max TCP distance)`` from the shoulder, metres (measured
        once per robot and process)."""
        return reach.workspace(self)

    def could_reach(
        self,
        position: ArrayLike,
        orientation: ArrayLike | None = None,
        margin: float = 0.0,
    ) -> bool:
        """Cheap necessary condition for a TCP pose to be reachable (workspace spheres)."""
        return reach.could_reach(self, position, orientation, margin)

    # ---------------------------------------------------------------- collisions
    def base_collisions(self, bodies: Iterable[int], margin: float = 0.0) -> list[int]:
        """Bodies among ``bodies`` within ``margin`` of the base (footprint box and pillar)."""
        return collisions.base_collisions(self, bodies, margin)

    def arm_collisions(
        self,
        bodies: Iterable[int],
        *,
        allow: Iterable[int | tuple[int, int]] = (),
        margin: float = 0.0,
        self_collision: bool = True,
    ) -> list[Contact]:
        """Collisions of the arm and tool with ``bodies`` (and with the robot itself); the
        end-effector links may touch the ``allow`` bodies or ``(body, link)`` pairs, the
        arm links may not. See :func:`momakitchen.robots.collisions.arm_collisions`."""
        return collisions.arm_collisions(
            self, bodies, allow=allow, margin=margin, self_collision=self_collision
        )

    def _self_pairs(self) -> list[tuple[int, int]]:
        """Link pairs tested for self-collision (cached per robot)."""
        return collisions.self_pairs(self)

    # ---------------------------------------------------------------- tool (tools.py)
    def _gripper(self) -> ParallelGripperTool:
        if not isinstance(self.tool, ParallelGripperTool):
            raise MomaError(
                f"robot {self.name!r} has no gripper (end-effector {self.spec.end_effector!r})"
            )
        return self.tool

    def _suction(self) -> SuctionTool:
        if not isinstance(self.tool, SuctionTool):
            raise MomaError(f"robot {self.name!r} has no suction cup")
        return self.tool

    @property
    def max_opening(self) -> float:
        """Full opening of the gripper in metres (0 without a gripper)."""
        return self.tool.max_opening if isinstance(self.tool, ParallelGripperTool) else 0.0

    @property
    def cup_link(self) -> int | None:
        """Link index of the suction cup (None without one)."""
        return self.tool.cup_link if isinstance(self.tool, SuctionTool) else None

    @property
    def attached_body(self) -> int | None:
        """Body held by the suction cup, or None."""
        return self.tool.attached_body if isinstance(self.tool, SuctionTool) else None

    def gripper_opening(self) -> float:
        """Distance between the finger pads in metres."""
        return self._gripper().opening()

    def set_gripper_opening(self, opening: float) -> None:
        """Teleport the fingers to ``opening`` metres apart and hold them there."""
        self._gripper().set_opening(opening)

    def open_gripper(self) -> None:
        """Command the fingers fully open (takes effect as physics steps)."""
        self._gripper().open()

    def close_gripper(self) -> None:
        """Command the fingers closed with their force limit (takes effect as physics
        steps; an object between the fingers stops them)."""
        self._gripper().close()

    def is_grasping(
        self, body: int, min_force: float = 0.5, max_angle: float = math.radians(85)
    ) -> bool:
        """Both fingers press on ``body`` (see :meth:`ParallelGripperTool.is_grasping`)."""
        return self._gripper().is_grasping(body, min_force, max_angle)

    def suction_on(self, bodies: Iterable[int] | None = None) -> int | None:
        """Attach the nearest body touching the cup face (of ``bodies``, default all);
        returns its id, or None (see :meth:`SuctionTool.on`)."""
        return self._suction().on(bodies)

    def suction_off(self) -> None:
        """Release whatever the cup holds."""
        self._suction().off()

    # ---------------------------------------------------------------- motion in physics
    def drive_to(self, q: ArrayLike, steps: int = 240, *, tol: float = 1e-3) -> bool:
        """Drive the arm to ``q`` with position control, stepping physics.

        Steps the simulation (at most ``steps`` times, fewer once the joints are within
        ``tol`` rad of the target). Returns whether the target was reached.
        """
        target = np.clip(np.asarray(q, float), self.lower, self.upper)
        p.setJointMotorControlArray(
            self.body,
            self.arm_joints,
            p.POSITION_CONTROL,
            targetPositions=target.tolist(),
            forces=self.max_force.tolist(),
            physicsClientId=self.client,
        )
        for i in range(steps):
            p.stepSimulation(physicsClientId=self.client)
            if i % 10 == 9 and np.max(np.abs(self.joint_positions() - target)) < tol:
                return True
        return bool(np.max(np.abs(self.joint_positions() - target)) < tol)

    def move_tcp(
        self,
        position: ArrayLike,
        orientation: ArrayLike | None,
        n: int = 10,
        steps_per_waypoint: int = 40,
    ) -> bool:
        """Move the TCP along a straight line in physics; False if planning fails."""
        path = self.plan_line(position, orientation, n)
        if path is None:
            return False
        for q in path:
            self.drive_to(q, steps_per_waypoint)
        self.drive_to(path[-1], 120)
        return True

    def remove(self) -> None:
        """Remove the robot from its client."""
        if isinstance(self.tool, SuctionTool):
            self.tool.off()
        p.removeBody(self.body, physicsClientId=self.client)
