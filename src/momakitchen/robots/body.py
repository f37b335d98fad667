"""A robot's body in a PyBullet client: loading, joint indexing, base placement, FK.

:class:`RobotBody` is what the concern modules (``ik.py``, ``reach.py``,
``collisions.py``, ``tools.py``) work on; :class:`~momakitchen.robots.robot.Robot` adds
them to it as one API. Conventions: positions in metres (world frame), quaternions
``(x, y, z, w)``, joint vectors of shape ``(dof,)`` in the order of ``joint_names``.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from momakitchen.bullet import muted, p
from momakitchen.errors import MomaError
from momakitchen.robots.arms import RobotModel
from momakitchen.robots.spec import RobotSpec, get_robot_spec
from momakitchen.robots.urdf import (
    BASE_LINK,
    TCP_LINK,
    parse_urdf,
    robot_urdf_path,
)


def variant_key(name: str, mount_height: float | None) -> str:
    """Key of the per-process caches that depend on the mount height (self-collision
    pairs): the robot's name at its own height, ``name@height`` at another."""
    spec = get_robot_spec(name)
    if mount_height is None or mount_height == spec.mount_height:
        return name
    return f"{name}@{float(mount_height)!r}"


def _yaw_quaternion(yaw: float) -> tuple[float, float, float, float]:
    return (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))


@dataclass(frozen=True)
class ReachGeometry:
    """Where a robot's workspace spheres sit, fixed on its base.

    Attributes:
        flange_in_tcp: the flange origin in the TCP frame, shape ``(3,)`` (a rigid offset:
            both sit after the last arm joint).
        centre: sphere centre in the base frame, shape ``(3,)``.
        shoulder_offset: the shoulder's distance from joint 1's axis, metres.
    """

    flange_in_tcp: np.ndarray
    centre: np.ndarray
    shoulder_offset: float


class RobotBody:
    """One registered robot's URDF loaded into a PyBullet client, its joints indexed.

    Args:
        client_id: PyBullet physics client.
        name: registered robot name (``momakitchen.robots.ROBOTS``).
        mount_height: height of the arm mount above the floor in metres (default: the
            robot's own, ``spec.mount_height``); any height of
            :data:`~momakitchen.robots.spec.MOUNT_RANGE`.
    """

    def __init__(self, client_id: int, name: str, mount_height: float | None = None) -> None:
        self.spec: RobotSpec = get_robot_spec(name)
        self.model: RobotModel = self.spec.model
        self.client = int(client_id)
        self.name = name
        path = robot_urdf_path(name, mount_height)  # checks the height
        self.mount_height = float(self.spec.mount_height if mount_height is None else mount_height)
        # How far the arm stands above its nominal mount (0.0 at the robot's own height).
        self.mount_shift = self.mount_height - self.spec.mount_height
        self.cache_key = variant_key(name, self.mount_height)
        self.body = self._load(path)
        self._index_joints()
        self._check_tcp_axis()
        self._lighten_bare_links()
        # PyBullet caches the kinematic tree behind calculateJacobian, its IK and inverse
        # dynamics by body and does not drop it when a body is removed, so a robot loaded
        # where another body was may inherit a stale tree. Nothing here uses those
        # functions (IK and Jacobians are computed from link states), and callers should
        # not either.
        self.reach_geometry = self._measure_reach_geometry()

    # ---------------------------------------------------------------- structure
    def _load(self, path) -> int:
        try:
            return muted(
                lambda: p.loadURDF(str(path), useFixedBase=True, physicsClientId=self.client)
            )
        except p.error as exc:
            raise MomaError(
                f"robot {self.name!r}: PyBullet cannot load {str(path)!r}: {exc}"
            ) from None

    def _index_joints(self) -> None:
        c = self.client
        n = p.getNumJoints(self.body, physicsClientId=c)
        infos = [p.getJointInfo(self.body, j, physicsClientId=c) for j in range(n)]
        self.link_names: list[str] = [info[12].decode() for info in infos]
        self.joint_name_list: list[str] = [info[1].decode() for info in infos]
        self._parent = [int(info[16]) for info in infos]  # parent link index of link j
        link_index = {name: j for j, name in enumerate(self.link_names)}
        link_index[BASE_LINK] = -1
        self._link_index = link_index
        ee = self.model.end_effector
        fingers = ee.finger_joints
        jidx = {name: j for j, name in enumerate(self.joint_name_list)}
        missing = [f for f in fingers if f not in jidx]
        if missing:
            raise MomaError(f"robot {self.name!r}: finger joints {missing} not in its URDF")
        self.finger_joints: list[int] = [jidx[f] for f in fingers]
        self._joint_infos = infos
        self.tcp_link = link_index[TCP_LINK]
        # Arm joints: the movable joints on the chain from the root to the TCP.
        chain, j = [], self.tcp_link
        while j >= 0:
            if infos[j][2] != p.JOINT_FIXED:
                chain.append(j)
            j = self._parent[j]
        self.arm_joints: list[int] = chain[::-1]
        if len(self.arm_joints) != self.spec.dof:
            raise MomaError(
                f"robot {self.name!r}: URDF has {len(self.arm_joints)} arm joints, "
                f"spec says dof={self.spec.dof}"
            )
        self.joint_names: list[str] = [self.joint_name_list[j] for j in self.arm_joints]
        self.lower = np.array([infos[j][8] for j in self.arm_joints])
        self.upper = np.array([infos[j][9] for j in self.arm_joints])
        # PyBullet reports continuous joints as upper < lower: one turn covers them.
        free = self.upper < self.lower
        self.lower[free], self.upper[free] = -math.pi, math.pi
        self.max_force = np.array([max(infos[j][10], 1.0) for j in self.arm_joints])
        # Joint axes in the child link frame (PyBullet's convention) for the Jacobian.
        self._axes_local = np.array([infos[j][13] for j in self.arm_joints], float)
        self._prismatic = np.array([infos[j][2] == p.JOINT_PRISMATIC for j in self.arm_joints])
        # PyBullet's Jacobian covers all movable joints, in joint-index order.
        self._movable = [j for j in range(n) if infos[j][2] != p.JOINT_FIXED]
        self._ik_cols = [self._movable.index(j) for j in self.arm_joints]
        mid = (self.lower + self.upper) / 2
        home = np.array(self.model.home, float) if self.model.home else mid
        if home.shape != (self.spec.dof,):
            raise MomaError(f"robot {self.name!r}: home needs {self.spec.dof} values")
        self.home = np.clip(home, self.lower, self.upper)
        self.flange_link = link_index[self.model.arm.flange_link]
        # Shoulder: the frame of the second arm joint (where reach is measured from).
        self.shoulder_link = self.arm_joints[1]
        # End-effector links: everything below the last arm joint's link (tool contacts
        # with an allowed target are intended, arm contacts are not).
        last = self.arm_joints[-1]
        self.ee_links = {j for j in range(n) if self._descends(j, last) and j != last}

    def _check_tcp_axis(self) -> None:
        """A user's TCP frame must have z out of the tool (the approach direction): the
        trials approach along it, so a frame turned back into the arm makes every
        approach drive the wrist into the target. The TCP is rigid on the last arm
        joint's link, so any configuration tells."""
        c = self.client
        last = self.arm_joints[-1]
        wrist = p.getLinkState(self.body, last, computeForwardKinematics=True, physicsClientId=c)
        tcp = p.getLinkState(
            self.body, self.tcp_link, computeForwardKinematics=True, physicsClientId=c
        )
        out = np.subtract(tcp[4], wrist[4])
        z = np.array(p.getMatrixFromQuaternion(tcp[5])).reshape(3, 3)[:, 2]
        length = float(np.linalg.norm(out))
        # Beyond 2 cm from the wrist, z more than 120 degrees away from the tool's
        # direction is a frame turned back, not a tool mounted off-axis.
        if length > 0.02 and float(out @ z) < -0.5 * length:
            tool = self.model.end_effector
            raise MomaError(
                f"robot {self.name!r}: the z axis of end_effector_link {tool.tcp_link!r} "
                f"points back into the arm ({float(out @ z) / length:.2f} along the wrist-to-"
                "TCP direction); z must point out of the tool (the approach direction)"
            )

    def _lighten_bare_links(self) -> None:
        """Links of a user's URDF without ``<inertial>`` (bare frames such as ``tool0``)
        weigh 1 g, not the 1 kg PyBullet gives them: a frame on the tool is no payload."""
        for link in parse_urdf(self.model.arm.urdf).findall("link"):
            j = self._link_index.get(link.get("name", ""))
            if link.find("inertial") is None and j is not None and j >= 0:
                p.changeDynamics(
                    self.body,
                    j,
                    mass=0.001,
                    localInertiaDiagonal=[1e-6] * 3,
                    physicsClientId=self.client,
                )

    def _descends(self, j: int, ancestor: int) -> bool:
        while j >= 0:
            if j == ancestor:
                return True
            j = self._parent[j]
        return False

    def link_index(self, name: str) -> int:
        """PyBullet link index of a link name (``mobile_base`` is -1)."""
        try:
            return self._link_index[name]
        except KeyError:
            raise MomaError(f"robot {self.name!r} has no link {name!r}") from None

    @property
    def dof(self) -> int:
        return self.spec.dof

    # ---------------------------------------------------------------- base
    def place_base(self, x: float, y: float, yaw: float) -> None:
        """Teleport the base to floor position ``(x, y)`` facing ``yaw`` (radians)."""
        p.resetBasePositionAndOrientation(
            self.body,
            (float(x), float(y), 0.0),
            _yaw_quaternion(float(yaw)),
            physicsClientId=self.client,
        )

    def base_pose(self) -> tuple[float, float, float]:
        """Current ``(x, y, yaw)`` of the base."""
        pos, orn = p.getBasePositionAndOrientation(self.body, physicsClientId=self.client)
        yaw = p.getEulerFromQuaternion(orn)[2]
        return (pos[0], pos[1], yaw)

    # ---------------------------------------------------------------- joints and FK
    def joint_positions(self) -> np.ndarray:
        """Arm joint positions, shape ``(dof,)``."""
        states = p.getJointStates(self.body, self.arm_joints, physicsClientId=self.client)
        return np.array([s[0] for s in states])

    def _reset_arm(self, q: ArrayLike) -> None:
        # One call for all joints: five times faster than resetJointState per joint.
        p.resetJointStatesMultiDof(
            self.body,
            self.arm_joints,
            np.asarray(q, float).reshape(-1, 1).tolist(),
            physicsClientId=self.client,
        )

    @contextmanager
    def kinematic_scratch(self) -> Iterator[None]:
        """Move the arm kinematically inside (IK, FK previews) and get the exact physical
        joint state back afterwards (positions and velocities), e.g. mid-manipulation."""
        saved = p.getJointStates(self.body, self.arm_joints, physicsClientId=self.client)
        try:
            yield
        finally:
            for j, s in zip(self.arm_joints, saved, strict=True):
                p.resetJointState(self.body, j, s[0], s[1], physicsClientId=self.client)

    def set_joint_positions(self, q: ArrayLike) -> None:
        """Teleport the arm to ``q`` (shape ``(dof,)``) and hold it there with the motors."""
        q = np.asarray(q, float)
        if q.shape != (self.dof,):
            raise MomaError(f"robot {self.name!r}: expected {self.dof} joint values, got {q.shape}")
        self._reset_arm(q)
        p.setJointMotorControlArray(
            self.body,
            self.arm_joints,
            p.POSITION_CONTROL,
            targetPositions=q.tolist(),
            forces=self.max_force.tolist(),
            physicsClientId=self.client,
        )

    def within_limits(self, q: ArrayLike, tol: float = 1e-6) -> bool:
        q = np.asarray(q, float)
        return bool(np.all(q >= self.lower - tol) and np.all(q <= self.upper + tol))

    def link_pose(self, link: int) -> tuple[np.ndarray, np.ndarray]:
        """World pose ``(position (3,), quaternion (4,))`` of a link's URDF frame."""
        if link == -1:
            pos, orn = p.getBasePositionAndOrientation(self.body, physicsClientId=self.client)
            return np.array(pos), np.array(orn)
        st = p.getLinkState(
            self.body, link, computeForwardKinematics=True, physicsClientId=self.client
        )
        return np.array(st[4]), np.array(st[5])

    def tcp_pose(self, q: ArrayLike | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Forward kinematics of the TCP: world ``(position (3,), quaternion (4,))``.

        With ``q``, the pose at that configuration (the current one is restored).
        """
        return self._pose_at(self.tcp_link, q)

    def flange_pose(self, q: ArrayLike | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Forward kinematics of the tool flange (same conventions as :meth:`tcp_pose`)."""
        return self._pose_at(self.flange_link, q)

    def _pose_at(self, link: int, q) -> tuple[np.ndarray, np.ndarray]:
        if q is None:
            return self.link_pose(link)
        saved = self.joint_positions()
        self._reset_arm(q)
        pose = self.link_pose(link)
        self._reset_arm(saved)
        return pose

    def shoulder_position(self) -> np.ndarray:
        """World position of the shoulder (second arm joint), shape ``(3,)``."""
        return self.link_pose(self.shoulder_link)[0]

    def _measure_reach_geometry(self) -> ReachGeometry:
        """Where the reach spheres sit, from the current link frames."""
        tcp_pos, tcp_orn = self.link_pose(self.tcp_link)
        fl_pos, _ = self.link_pose(self.flange_link)
        tcp_rot = np.array(p.getMatrixFromQuaternion(tcp_orn)).reshape(3, 3)
        flange_in_tcp = tcp_rot.T @ (fl_pos - tcp_pos)
        first = self.arm_joints[0]
        axis_pos, axis_orn = self.link_pose(first)
        axis = np.array(p.getMatrixFromQuaternion(axis_orn)).reshape(3, 3) @ self._axes_local[0]
        shoulder = self.link_pose(self.shoulder_link)[0]
        centre = axis_pos + float((shoulder - axis_pos) @ axis) * axis
        shoulder_offset = float(np.linalg.norm(shoulder - centre))
        bpos, born = p.getBasePositionAndOrientation(self.body, physicsClientId=self.client)
        brot = np.array(p.getMatrixFromQuaternion(born)).reshape(3, 3)
        return ReachGeometry(flange_in_tcp, brot.T @ (centre - np.asarray(bpos)), shoulder_offset)
