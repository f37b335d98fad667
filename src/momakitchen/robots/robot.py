"""A mobile manipulator in a PyBullet client: placement, FK, IK, collisions, tools.

Every PyBullet call passes the robot's ``client_id``, so robots in several independent
DIRECT clients of one process do not interfere. The base is fixed (teleported, not
driven): last-mile navigation only needs the stopping pose.

Conventions: positions in metres (world frame), quaternions ``(x, y, z, w)`` as PyBullet
uses them, joint vectors of shape ``(dof,)`` in the order of :attr:`Robot.joint_names`.
The TCP frame's z axis is the approach direction; gripper fingers close along its y axis.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from momakitchen.bullet import connect_direct, p
from momakitchen.errors import MomaError
from momakitchen.robots.arms import (
    ParallelGripper,
    RobotModel,
    ShippedArm,
    SuctionCup,
    UserTool,
    get_model,
)
from momakitchen.robots.spec import RobotSpec, get_robot_spec
from momakitchen.robots.urdf import (
    BASE_LINK,
    CUP_HEIGHT,
    FINGER_JOINTS,
    SUCTION_LINK,
    TCP_LINK,
    robot_urdf_path,
)

# A few thousand random configurations give the workspace radius to within ~1 %.
_WORKSPACE_SAMPLES = 1500
_WORKSPACE_CACHE: dict[str, tuple[float, float]] = {}
_SELF_PAIRS_CACHE: dict[str, list[tuple[int, int]]] = {}
_SEED_LIBRARY: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
_WARMING: set[str] = set()


def _warm_caches(name: str) -> None:
    """Compute a robot's per-process caches (workspace, self-collision pairs, IK seed
    library) once, in a scratch client of their own.

    Computing them lazily inside a world would teleport its joints thousands of times in
    the middle of whatever that world was doing, and PyBullet's results depend, in the
    last bits, on such history: with the caches warmed apart, a world's results depend
    only on what is done in it.
    """
    if name in _WARMING or (name in _WORKSPACE_CACHE and name in _SELF_PAIRS_CACHE
                            and name in _SEED_LIBRARY):
        return
    _WARMING.add(name)
    client = connect_direct()
    try:
        robot = Robot(client, name)
        robot.workspace()
        robot._self_pairs()
        _SEED_LIBRARY.setdefault(name, robot._build_library())
    finally:
        p.disconnect(client)
        _WARMING.discard(name)
_EYE3, _EYE6 = np.eye(3), np.eye(6)


@dataclass(frozen=True)
class IKResult:
    """Outcome of :meth:`Robot.solve_ik`.

    Attributes:
        q: joint positions, shape ``(dof,)``, always within the joint limits.
        position_error: TCP position residual in metres.
        orientation_error: TCP orientation residual in radians (0 if not constrained).
        success: both residuals within the requested tolerances.
        calls: Levenberg-Marquardt iterations used (over all attempts).
        seconds: wall time of the solve.
    """

    q: np.ndarray
    position_error: float
    orientation_error: float
    success: bool
    calls: int
    seconds: float


@dataclass(frozen=True)
class Contact:
    """A collision found by :meth:`Robot.arm_collisions`.

    Attributes:
        link: robot link name (``"mobile_base"`` for the base).
        body: the other body id (the robot's own id for a self-collision).
        other_link: link index on the other body (-1 = its base).
        distance: signed distance in metres (negative = penetration).
    """

    link: str
    body: int
    other_link: int
    distance: float


def quaternion_angle(q1: Sequence[float], q2: Sequence[float]) -> float:
    """Angle in radians of the rotation between two unit quaternions ``(x, y, z, w)``."""
    dot = abs(float(np.dot(np.asarray(q1, float), np.asarray(q2, float))))
    return 2.0 * math.acos(min(1.0, dot))


_LEVI_CIVITA = np.zeros((3, 3, 3))
_LEVI_CIVITA[0, 1, 2] = _LEVI_CIVITA[1, 2, 0] = _LEVI_CIVITA[2, 0, 1] = 1.0
_LEVI_CIVITA[0, 2, 1] = _LEVI_CIVITA[2, 1, 0] = _LEVI_CIVITA[1, 0, 2] = -1.0


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross product, ``(n, 3) x (n, 3) or (3,) -> (n, 3)`` (np.cross is several
    times slower at this size, and IK calls this thousands of times)."""
    if b.ndim == 1:
        return np.einsum("ijk,nj,k->ni", _LEVI_CIVITA, a, b)
    return np.einsum("ijk,nj,nk->ni", _LEVI_CIVITA, a, b)


def _yaw_quaternion(yaw: float) -> tuple[float, float, float, float]:
    return (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))


class Robot:
    """One registered robot loaded into a PyBullet client.

    Args:
        client_id: PyBullet physics client (e.g. from ``p.connect(p.DIRECT)``).
        name: registered robot name (``momakitchen.robots.ROBOTS``).
        base: initial base pose ``(x, y, yaw)``.
    """

    def __init__(self, client_id: int, name: str, base: Sequence[float] = (0.0, 0.0, 0.0)):
        self.spec: RobotSpec = get_robot_spec(name)
        self.model: RobotModel = get_model(name)
        self.client = int(client_id)
        self.name = name
        _warm_caches(name)
        path = robot_urdf_path(name)
        self.body = self._load(path)
        self._index_joints()
        # PyBullet caches the kinematic tree behind calculateJacobian, its IK and inverse
        # dynamics by body and does not drop it when a body is removed, so a robot loaded
        # where another body was may inherit a stale tree. Nothing here uses those
        # functions (IK and Jacobians are computed from link states), and callers should
        # not either.
        self._attachment: tuple[int, int] | None = None
        # The flange in the TCP frame: a rigid offset (both sit after the last arm joint).
        tcp_pos, tcp_orn = self.link_pose(self.tcp_link)
        fl_pos, _ = self.link_pose(self.flange_link)
        tcp_rot = np.array(p.getMatrixFromQuaternion(tcp_orn)).reshape(3, 3)
        self._flange_in_tcp = tcp_rot.T @ (fl_pos - tcp_pos)
        # Reach spheres: centred where the shoulder projects onto joint 1's axis (a point
        # fixed on the base), grown by the shoulder's distance from that axis.
        first = self.arm_joints[0]
        axis_pos, axis_orn = self.link_pose(first)
        axis = np.array(p.getMatrixFromQuaternion(axis_orn)).reshape(3, 3) @ self._axes_local[0]
        shoulder = self.link_pose(self.shoulder_link)[0]
        centre = axis_pos + float((shoulder - axis_pos) @ axis) * axis
        self._shoulder_offset = float(np.linalg.norm(shoulder - centre))
        bpos, born = p.getBasePositionAndOrientation(self.body, physicsClientId=self.client)
        brot = np.array(p.getMatrixFromQuaternion(born)).reshape(3, 3)
        self._reach_centre = brot.T @ (centre - np.asarray(bpos))
        self.place_base(*base)
        self.set_joint_positions(self.home)
        if self.finger_joints:
            for j in self.finger_joints:
                p.changeDynamics(self.body, j, lateralFriction=1.5, spinningFriction=0.01,
                                 physicsClientId=self.client)
            self.set_gripper_opening(self.max_opening)

    # ---------------------------------------------------------------- structure
    def _load(self, path) -> int:
        try:
            return p.loadURDF(str(path), useFixedBase=True, physicsClientId=self.client)
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
        if isinstance(ee, ParallelGripper):
            fingers = ee.existing_fingers or FINGER_JOINTS
        elif isinstance(ee, UserTool):
            fingers = ee.finger_joints
        else:
            fingers = ()
        jidx = {name: j for j, name in enumerate(self.joint_name_list)}
        missing = [f for f in fingers if f not in jidx]
        if missing:
            raise MomaError(f"robot {self.name!r}: finger joints {missing} not in its URDF")
        self.finger_joints: list[int] = [jidx[f] for f in fingers]
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
        if self.finger_joints:
            self.max_opening = float(sum(infos[j][9] for j in self.finger_joints))
            self.finger_force = float(getattr(ee, "finger_force", 40.0))
        else:
            self.max_opening = 0.0
        # Flange: the model's flange link (shipped arm), "flange" (built arm), else the TCP.
        if isinstance(self.model.arm, ShippedArm) and not isinstance(ee, UserTool):
            self.flange_link = link_index[self.model.arm.flange_link]
        else:
            self.flange_link = link_index.get("flange", self.tcp_link)
        # Shoulder: the frame of the second arm joint (where reach is measured from).
        self.shoulder_link = self.arm_joints[1]
        # End-effector links: everything below the last arm joint's link (tool contacts
        # with an allowed target are intended, arm contacts are not).
        last = self.arm_joints[-1]
        self.ee_links = {j for j in range(n) if self._descends(j, last) and j != last}
        if isinstance(ee, SuctionCup):
            self.cup_link = link_index[SUCTION_LINK]
        elif isinstance(ee, UserTool) and ee.kind == "suction":
            self.cup_link = self._parent[self.tcp_link]
        else:
            self.cup_link = None

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
        p.resetBasePositionAndOrientation(self.body, (float(x), float(y), 0.0),
                                          _yaw_quaternion(float(yaw)),
                                          physicsClientId=self.client)

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

    def _reset_arm(self, q: Sequence[float]) -> None:
        # One call for all joints: five times faster than resetJointState per joint.
        p.resetJointStatesMultiDof(self.body, self.arm_joints,
                                   np.asarray(q, float).reshape(-1, 1).tolist(),
                                   physicsClientId=self.client)

    def set_joint_positions(self, q: Sequence[float]) -> None:
        """Teleport the arm to ``q`` (shape ``(dof,)``) and hold it there with the motors."""
        q = np.asarray(q, float)
        if q.shape != (self.dof,):
            raise MomaError(f"robot {self.name!r}: expected {self.dof} joint values, got {q.shape}")
        self._reset_arm(q)
        p.setJointMotorControlArray(self.body, self.arm_joints, p.POSITION_CONTROL,
                                    targetPositions=q.tolist(), forces=self.max_force.tolist(),
                                    physicsClientId=self.client)

    def within_limits(self, q: Sequence[float], tol: float = 1e-6) -> bool:
        q = np.asarray(q, float)
        return bool(np.all(q >= self.lower - tol) and np.all(q <= self.upper + tol))

    def link_pose(self, link: int) -> tuple[np.ndarray, np.ndarray]:
        """World pose ``(position (3,), quaternion (4,))`` of a link's URDF frame."""
        if link == -1:
            pos, orn = p.getBasePositionAndOrientation(self.body, physicsClientId=self.client)
            return np.array(pos), np.array(orn)
        st = p.getLinkState(self.body, link, computeForwardKinematics=True,
                            physicsClientId=self.client)
        return np.array(st[4]), np.array(st[5])

    def tcp_pose(self, q: Sequence[float] | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Forward kinematics of the TCP: world ``(position (3,), quaternion (4,))``.

        With ``q``, the pose at that configuration (the current one is restored).
        """
        return self._pose_at(self.tcp_link, q)

    def flange_pose(self, q: Sequence[float] | None = None) -> tuple[np.ndarray, np.ndarray]:
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

    # ---------------------------------------------------------------- IK
    def solve_ik(
        self,
        position: Sequence[float],
        orientation: Sequence[float] | None = None,
        *,
        seed: Sequence[float] | None = None,
        pos_tol: float = 0.005,
        ori_tol: float = math.radians(2.0),
        iterations: int = 40,
        restarts: int = 8,
        rng: np.random.Generator | None = None,
    ) -> IKResult:
        """Joint positions placing the TCP at ``position`` (and ``orientation``).

        Damped least squares (Levenberg-Marquardt) on PyBullet's FK and Jacobian, joint
        limits enforced by clipping each step; from ``seed`` first, then from the home
        configuration, then from random configurations (``restarts`` in all). PyBullet's
        ``calculateInverseKinematics`` is not used: with limits it stalls millimetres
        short of the target. Residuals are measured by FK, so ``success`` never lies;
        the solver aims at a tenth of the tolerances. The arm is left at the best
        configuration found.

        Args:
            position: target TCP position in the world frame, shape ``(3,)``.
            orientation: target TCP quaternion ``(x, y, z, w)`` or None (position only).
            seed: start configuration, shape ``(dof,)`` (default: current joints).
        """
        t0 = time.perf_counter()
        target = np.asarray(position, float)
        if target.shape != (3,) or not np.all(np.isfinite(target)):
            raise MomaError(f"IK position must be 3 finite numbers, got {position!r}")
        target_rot = None
        if orientation is not None:
            quat = np.asarray(orientation, float)
            norm = float(np.linalg.norm(quat)) if quat.shape == (4,) else 0.0
            if not 0.5 < norm < 2.0:
                raise MomaError(f"IK orientation must be a unit quaternion, got {orientation!r}")
            target_rot = np.array(p.getMatrixFromQuaternion((quat / norm).tolist())).reshape(3, 3)
        rng = rng if rng is not None else np.random.default_rng(0)
        slack = pos_tol + 0.01  # the sampled workspace radii may fall a little short
        if not self._within_reach(target, target_rot, slack):
            # Outside the workspace sphere: no configuration can do it.
            pos, cur = self.tcp_pose()
            oerr = 0.0
            if target_rot is not None:
                rot = np.array(p.getMatrixFromQuaternion(cur)).reshape(3, 3)
                oerr = math.acos(min(1.0, max(-1.0, (np.trace(target_rot @ rot.T) - 1) / 2)))
            return IKResult(q=self.joint_positions(),
                            position_error=float(np.linalg.norm(pos - target)),
                            orientation_error=oerr, success=False, calls=0,
                            seconds=time.perf_counter() - t0)
        seeds = [np.asarray(seed if seed is not None else self.joint_positions(), float),
                 self.home]
        best: tuple[float, float, np.ndarray] | None = None
        calls = 0
        for attempt in range(restarts + 1):
            if attempt == 2:  # the easy seeds failed: look up the library (built lazily)
                seeds += self._library_seeds(target, target_rot, restarts - 1)
            q0 = seeds[attempt] if attempt < len(seeds) else rng.uniform(self.lower, self.upper)
            q, perr, oerr, n = self._lm(q0, target, target_rot, iterations, pos_tol, ori_tol)
            calls += n
            if best is None or perr + 0.1 * oerr < best[0] + 0.1 * best[1]:
                best = (perr, oerr, q)
            if perr <= pos_tol and oerr <= ori_tol:
                break
        perr, oerr, q = best
        self._reset_arm(q)
        return IKResult(q=q, position_error=perr, orientation_error=oerr,
                        success=perr <= pos_tol and oerr <= ori_tol, calls=calls,
                        seconds=time.perf_counter() - t0)

    def _library_seeds(self, target: np.ndarray, target_rot: np.ndarray | None,
                       k: int) -> list[np.ndarray]:
        """The ``k`` configurations of a sampled library whose TCP pose is nearest the
        target (in the base frame): far better restarts than uniform random ones."""
        if k <= 0:
            return []
        if self.name not in _SEED_LIBRARY:
            _SEED_LIBRARY[self.name] = self._build_library()
        qs, pos, zax = _SEED_LIBRARY[self.name]
        bpos, born = p.getBasePositionAndOrientation(self.body, physicsClientId=self.client)
        brot = np.array(p.getMatrixFromQuaternion(born)).reshape(3, 3)
        local = brot.T @ (target - np.array(bpos))
        dist = np.linalg.norm(pos - local, axis=1)
        if target_rot is not None:
            # Approach direction matters most for the wrist: compare the TCP z axes.
            dist = dist + 0.15 * np.linalg.norm(zax - brot.T @ target_rot[:, 2], axis=1)
        return list(qs[np.argsort(dist)[:k]])

    def _build_library(self, n: int = 1500) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Random configurations with their TCP position and z axis in the base frame."""
        rng = np.random.default_rng(1)
        saved = self.joint_positions()
        bpos, born = p.getBasePositionAndOrientation(self.body, physicsClientId=self.client)
        brot = np.array(p.getMatrixFromQuaternion(born)).reshape(3, 3)
        qs = rng.uniform(self.lower, self.upper, size=(n, self.dof))
        pos, zax = np.empty((n, 3)), np.empty((n, 3))
        for i, q in enumerate(qs):
            self._reset_arm(q)
            wp, wq = self.link_pose(self.tcp_link)
            pos[i] = brot.T @ (wp - np.array(bpos))
            zax[i] = brot.T @ np.array(p.getMatrixFromQuaternion(wq)).reshape(3, 3)[:, 2]
        self._reset_arm(saved)
        return qs, pos, zax

    def _lm(self, q: np.ndarray, target: np.ndarray, target_rot: np.ndarray | None,
            iterations: int, pos_tol: float, ori_tol: float
            ) -> tuple[np.ndarray, float, float, int]:
        """Levenberg-Marquardt from ``q``; returns ``(q, pos err, ori err, iterations)``.

        The geometric Jacobian is assembled from the joint frames (one getLinkStates
        call): PyBullet's calculateJacobian is off by up to ~1 cm/rad on these models.
        """
        c = self.client
        q = np.clip(q, self.lower, self.upper)
        links = [*self.arm_joints, self.tcp_link]
        axes_local = self._axes_local
        lam = 1e-4
        prev = math.inf
        last_gain = 0
        perr = oerr = math.inf
        for it in range(iterations + 1):
            self._reset_arm(q)
            states = p.getLinkStates(self.body, links, computeForwardKinematics=True,
                                     physicsClientId=c)
            tcp_pos = np.array(states[-1][4])
            e_pos = target - tcp_pos
            perr = math.sqrt(float(e_pos @ e_pos))
            if target_rot is not None:
                rot = np.array(p.getMatrixFromQuaternion(states[-1][5])).reshape(3, 3)
                r_err = target_rot @ rot.T
                oerr = math.acos(min(1.0, max(-1.0, (np.trace(r_err) - 1) / 2)))
            else:
                oerr = 0.0
            # Aim well inside the tolerances so that small model noise keeps success.
            if (perr <= 0.1 * pos_tol and oerr <= 0.1 * ori_tol) or it == iterations:
                return q, perr, oerr, it
            cost = perr + 0.2 * oerr
            # Adapt the damping: shrink after progress, grow after a bad step.
            lam = max(lam * 0.3, 1e-6) if cost < prev else min(lam * 10, 1.0)
            if cost < 0.97 * prev:
                last_gain = it
            elif it - last_gain >= 6:
                return q, perr, oerr, it  # stuck (joint limits, local minimum): restart
            prev = min(prev, cost)
            frames = np.array([st[4] + st[5] for st in states[:-1]])  # (n, 7)
            pos, quat = frames[:, :3], frames[:, 3:]
            # Rotate the local axes by the joint frames' quaternions: v + 2w(u x v) + 2u x (u x v).
            u, w = quat[:, :3], quat[:, 3:4]
            uv = _cross(u, axes_local)
            axes = axes_local + 2 * w * uv + 2 * _cross(u, uv)
            jv = np.where(self._prismatic[:, None], axes, _cross(axes, tcp_pos - pos))
            if target_rot is not None:
                vee = np.array([r_err[2, 1] - r_err[1, 2], r_err[0, 2] - r_err[2, 0],
                                r_err[1, 0] - r_err[0, 1]])
                sin = math.sin(oerr)
                e_rot = vee * (oerr / (2 * sin) if sin > 1e-6 else 0.5)
                if oerr > 3.0:  # the vee map vanishes near pi: push about the tool's x axis
                    e_rot = e_rot + 0.5 * rot[:, 0]
                jw = np.where(self._prismatic[:, None], 0.0, axes)
                jac = np.concatenate([jv, jw], axis=1).T  # (6, n)
                err = np.concatenate([e_pos, e_rot])
                eye = _EYE6
            else:
                jac = jv.T
                err = e_pos
                eye = _EYE3
            dq = jac.T @ np.linalg.solve(jac @ jac.T + lam * eye, err)
            big = float(np.max(np.abs(dq)))
            if big > 0.5:  # large steps overshoot on the nonlinear map
                dq *= 0.5 / big
            q = np.clip(q + dq, self.lower, self.upper)
        return q, perr, oerr, iterations

    # ---------------------------------------------------------------- reachability
    def workspace(self) -> tuple[float, float]:
        """``(max flange distance, max TCP distance)`` from the shoulder, metres.

        Measured over random joint configurations within the limits (cached per robot).
        """
        if self.name not in _WORKSPACE_CACHE:
            _WORKSPACE_CACHE[self.name] = measure_workspace(self, _WORKSPACE_SAMPLES)
        return _WORKSPACE_CACHE[self.name]

    def could_reach(self, position: Sequence[float], orientation: Sequence[float] | None = None,
                    margin: float = 0.0) -> bool:
        """Cheap necessary condition for a TCP pose to be reachable.

        Without ``orientation``: the TCP lies within the TCP workspace sphere. With it, also
        the tighter test: the flange, rigidly offset from the TCP, lies within the flange
        workspace sphere. The spheres are centred on joint 1's axis at shoulder height and
        grown by the shoulder's offset from that axis (the shoulder turns with joint 1).
        """
        rot = None
        if orientation is not None:
            quat = [float(v) for v in orientation]
            rot = np.array(p.getMatrixFromQuaternion(quat)).reshape(3, 3)
        return self._within_reach(np.asarray(position, float), rot, margin)

    def _within_reach(self, tcp_pos: np.ndarray, tcp_rot: np.ndarray | None,
                      margin: float) -> bool:
        flange_reach, tcp_reach = self.workspace()
        bpos, born = p.getBasePositionAndOrientation(self.body, physicsClientId=self.client)
        brot = np.array(p.getMatrixFromQuaternion(born)).reshape(3, 3)
        centre = np.asarray(bpos) + brot @ self._reach_centre
        grow = self._shoulder_offset + margin
        if float(np.linalg.norm(tcp_pos - centre)) > tcp_reach + grow:
            return False
        if tcp_rot is None:
            return True
        flange = tcp_pos + tcp_rot @ self._flange_in_tcp
        return float(np.linalg.norm(flange - centre)) <= flange_reach + grow

    # ---------------------------------------------------------------- collisions
    def base_collisions(self, bodies: Iterable[int], margin: float = 0.0) -> list[int]:
        """Bodies among ``bodies`` within ``margin`` of the base (footprint box and pillar)."""
        hits = []
        for b in bodies:
            if b == self.body:
                continue
            if p.getClosestPoints(self.body, b, margin, linkIndexA=-1,
                                  physicsClientId=self.client):
                hits.append(b)
        return hits

    def arm_collisions(
        self,
        bodies: Iterable[int],
        *,
        allow: Iterable[int | tuple[int, int]] = (),
        margin: float = 0.0,
        self_collision: bool = True,
    ) -> list[Contact]:
        """Collisions of the arm and tool with ``bodies`` (and with the robot itself).

        Args:
            bodies: world bodies to test (the floor may be included; the base is not
                tested here, see :meth:`base_collisions`).
            allow: intended contacts: a body id or a ``(body, link)`` pair that the
                end-effector links may touch (the target). The arm links may not.
            margin: report pairs closer than this (metres); 0 = touching/penetrating.
            self_collision: also test arm links against the base and non-adjacent links.
        """
        allowed_bodies, allowed_pairs = set(), set()
        for a in allow:
            if isinstance(a, tuple):
                allowed_pairs.add((int(a[0]), int(a[1])))
            else:
                allowed_bodies.add(int(a))
        out = []
        c = self.client
        for b in bodies:
            if b == self.body:
                continue
            for pt in p.getClosestPoints(self.body, b, margin, physicsClientId=c):
                link, other = pt[3], pt[4]
                if link == -1:
                    continue
                if link in self.ee_links and (b in allowed_bodies or (b, other) in allowed_pairs):
                    continue
                out.append(Contact(self.link_names[link], b, other, float(pt[8])))
        if self_collision:
            for la, lb in self._self_pairs():
                pts = p.getClosestPoints(self.body, self.body, margin, linkIndexA=la,
                                         linkIndexB=lb, physicsClientId=c)
                if pts:
                    name = BASE_LINK if la == -1 else self.link_names[la]
                    out.append(Contact(name, self.body, lb, float(min(x[8] for x in pts))))
        return out

    def _self_pairs(self) -> list[tuple[int, int]]:
        """Link pairs tested for self-collision: not within two joints of each other and
        not touching at the home configuration (like an SRDF's disabled pairs)."""
        if self.name in _SELF_PAIRS_CACHE:
            return _SELF_PAIRS_CACHE[self.name]
        c = self.client
        n = len(self.link_names)
        links = [-1] + [j for j in range(n)
                        if p.getCollisionShapeData(self.body, j, physicsClientId=c)]

        def hops(a: int, b: int) -> int:
            def up(j):
                path = [j]
                while j >= 0:
                    j = self._parent[j]
                    path.append(j)
                return path
            pa, pb = up(a), up(b)
            common = next(x for x in pa if x in pb)
            return pa.index(common) + pb.index(common)

        saved = self.joint_positions()
        saved_fingers = [p.getJointState(self.body, j, physicsClientId=c)[0]
                         for j in self.finger_joints]
        self._reset_arm(self.home)
        pairs = []
        for i, a in enumerate(links):
            for b in links[i + 1:]:
                # Fingers and palm move against each other by design.
                if a in self.ee_links and b in self.ee_links:
                    continue
                if hops(a, b) <= 2:
                    continue
                if p.getClosestPoints(self.body, self.body, 0.0, linkIndexA=a, linkIndexB=b,
                                      physicsClientId=c):
                    continue
                pairs.append((a, b))
        self._reset_arm(saved)
        for j, v in zip(self.finger_joints, saved_fingers, strict=True):
            p.resetJointState(self.body, j, v, physicsClientId=c)
        _SELF_PAIRS_CACHE[self.name] = pairs
        return pairs

    # ---------------------------------------------------------------- gripper
    def _require_gripper(self) -> None:
        if not self.finger_joints:
            raise MomaError(f"robot {self.name!r} has no gripper (end-effector "
                            f"{self.spec.end_effector!r})")

    def gripper_opening(self) -> float:
        """Distance between the finger pads in metres."""
        self._require_gripper()
        states = p.getJointStates(self.body, self.finger_joints, physicsClientId=self.client)
        return float(sum(s[0] for s in states))

    def set_gripper_opening(self, opening: float) -> None:
        """Teleport the fingers to ``opening`` metres apart and hold them there."""
        self._require_gripper()
        half = float(np.clip(opening, 0.0, self.max_opening)) / 2
        for j in self.finger_joints:
            p.resetJointState(self.body, j, half, physicsClientId=self.client)
        self._drive_fingers(half)

    def _drive_fingers(self, half: float) -> None:
        # PyBullet ignores URDF mimic joints: each finger has its own motor.
        n = len(self.finger_joints)
        p.setJointMotorControlArray(self.body, self.finger_joints, p.POSITION_CONTROL,
                                    targetPositions=[half] * n,
                                    forces=[self.finger_force] * n,
                                    physicsClientId=self.client)

    def open_gripper(self) -> None:
        """Command the fingers fully open (takes effect as physics steps)."""
        self._require_gripper()
        self._drive_fingers(self.max_opening / 2)

    def close_gripper(self) -> None:
        """Command the fingers closed with their force limit (takes effect as physics
        steps; an object between the fingers stops them)."""
        self._require_gripper()
        self._drive_fingers(0.0)

    def is_grasping(self, body: int, min_force: float = 0.5,
                    max_angle: float = math.radians(85)) -> bool:
        """Both fingers press on ``body``: at least ``min_force`` newtons each, along
        contact normals within ``max_angle`` of the finger's closing direction (a tip
        resting on the object is not a grasp; ManiSkill's test has the same shape)."""
        self._require_gripper()
        c = self.client
        cos_max = math.cos(max_angle)
        for j in self.finger_joints:
            # Opening direction of this finger in the world (its prismatic axis).
            _, orn = self.link_pose(j)
            local = np.asarray(p.getJointInfo(self.body, j, physicsClientId=c)[13], float)
            opening = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3) @ local
            force = 0.0
            for pt in p.getContactPoints(self.body, body, linkIndexA=j, physicsClientId=c):
                # The normal on the object points from the object to the finger, i.e. along
                # the finger's opening direction when the finger squeezes the object.
                if float(np.dot(pt[7], opening)) >= cos_max:
                    force += pt[9]
            if force < min_force:
                return False
        return True

    # ---------------------------------------------------------------- suction
    def _require_suction(self) -> None:
        if self.cup_link is None:
            raise MomaError(f"robot {self.name!r} has no suction cup")

    @property
    def attached_body(self) -> int | None:
        """Body held by the suction cup, or None."""
        return None if self._attachment is None else self._attachment[1]

    def suction_on(self, bodies: Iterable[int] | None = None) -> int | None:
        """Switch suction on: attach the nearest body whose surface touches the cup face.

        Attaches (a fixed constraint holding the current relative pose) only if a surface
        is within the cup's contact distance of the cup face; otherwise nothing happens.

        Args:
            bodies: candidate bodies (default: every other body in the client).
        Returns:
            the attached body id, or None.
        """
        self._require_suction()
        if self._attachment is not None:
            return self._attachment[1]
        c = self.client
        ee = self.model.end_effector
        reach = float(getattr(ee, "contact_distance", 0.004))
        if bodies is None:
            bodies = [p.getBodyUniqueId(i, physicsClientId=c)
                      for i in range(p.getNumBodies(physicsClientId=c))]
        cup_pos, cup_orn = self.link_pose(self.cup_link)
        rot = np.array(p.getMatrixFromQuaternion(cup_orn)).reshape(3, 3)
        best = None
        for b in bodies:
            if b == self.body:
                continue
            for pt in p.getClosestPoints(self.body, b, reach, linkIndexA=self.cup_link,
                                         physicsClientId=c):
                # The contact must be on the cup face, not on its rim or side.
                local = rot.T @ (np.array(pt[5]) - cup_pos)
                if isinstance(ee, SuctionCup) and local[2] < CUP_HEIGHT - 0.004:
                    continue
                if best is None or pt[8] < best[2]:
                    best = (b, pt[4], pt[8])
        if best is None:
            return None
        body, link = best[0], best[1]
        # Constraint frames are relative to the links' centre-of-mass frames.
        st = p.getLinkState(self.body, self.cup_link, physicsClientId=c)
        cup_com = (st[0], st[1])
        if link == -1:
            obj_com = p.getBasePositionAndOrientation(body, physicsClientId=c)
        else:
            s2 = p.getLinkState(body, link, physicsClientId=c)
            obj_com = (s2[0], s2[1])
        inv_pos, inv_orn = p.invertTransform(obj_com[0], obj_com[1])
        rel_pos, rel_orn = p.multiplyTransforms(inv_pos, inv_orn, cup_com[0], cup_com[1])
        cid = p.createConstraint(self.body, self.cup_link, body, link, p.JOINT_FIXED,
                                 (0, 0, 0), (0, 0, 0), rel_pos, (0, 0, 0, 1), rel_orn,
                                 physicsClientId=c)
        p.changeConstraint(cid, maxForce=200.0, physicsClientId=c)
        self._attachment = (cid, body)
        return body

    def suction_off(self) -> None:
        """Release whatever the cup holds."""
        self._require_suction()
        if self._attachment is not None:
            p.removeConstraint(self._attachment[0], physicsClientId=self.client)
            self._attachment = None

    # ---------------------------------------------------------------- motion in physics
    def drive_to(self, q: Sequence[float], steps: int = 240, *, tol: float = 1e-3) -> bool:
        """Drive the arm to ``q`` with position control, stepping physics.

        Steps the simulation (at most ``steps`` times, fewer once the joints are within
        ``tol`` rad of the target). Returns whether the target was reached.
        """
        q = np.clip(np.asarray(q, float), self.lower, self.upper)
        p.setJointMotorControlArray(self.body, self.arm_joints, p.POSITION_CONTROL,
                                    targetPositions=q.tolist(), forces=self.max_force.tolist(),
                                    physicsClientId=self.client)
        for i in range(steps):
            p.stepSimulation(physicsClientId=self.client)
            if i % 10 == 9 and np.max(np.abs(self.joint_positions() - q)) < tol:
                return True
        return bool(np.max(np.abs(self.joint_positions() - q)) < tol)

    def plan_line(self, position: Sequence[float], orientation: Sequence[float] | None,
                  n: int = 10) -> list[np.ndarray] | None:
        """IK waypoints moving the TCP on a straight line to a pose, or None if any fails.

        The physical joint state (positions and velocities) is left untouched.
        """
        c = self.client
        saved = p.getJointStates(self.body, self.arm_joints, physicsClientId=c)
        start, _ = self.tcp_pose()
        goal = np.asarray(position, float)
        path, q = [], np.array([s[0] for s in saved])
        ok = True
        for k in range(1, n + 1):
            res = self.solve_ik(start + (goal - start) * k / n, orientation, seed=q, restarts=0)
            if not res.success:
                ok = False
                break
            q = res.q
            path.append(q)
        for j, s in zip(self.arm_joints, saved, strict=True):
            p.resetJointState(self.body, j, s[0], s[1], physicsClientId=c)
        return path if ok else None

    def move_tcp(self, position: Sequence[float], orientation: Sequence[float] | None,
                 n: int = 10, steps_per_waypoint: int = 40) -> bool:
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
        if self._attachment is not None:
            self.suction_off()
        p.removeBody(self.body, physicsClientId=self.client)


def measure_workspace(robot: Robot, samples: int = _WORKSPACE_SAMPLES,
                      seed: int = 0) -> tuple[float, float]:
    """``(max flange distance, max TCP distance)`` from the shoulder, metres.

    Random joint vectors within the limits, then a local random search from the best
    few (stretched-out configurations are rare among uniform samples). The robot's
    configuration is restored afterwards.
    """
    rng = np.random.default_rng(seed)
    saved = robot.joint_positions()
    links = [robot.shoulder_link, robot.flange_link, robot.tcp_link]

    def dists(q: np.ndarray) -> tuple[float, float]:
        robot._reset_arm(q)
        # One forward-kinematics call for the three links (the same values as three).
        sh, flange, tcp = (np.array(s[4]) for s in p.getLinkStates(
            robot.body, links, computeForwardKinematics=True, physicsClientId=robot.client))
        return float(np.linalg.norm(flange - sh)), float(np.linalg.norm(tcp - sh))

    result = []
    for which in (0, 1):
        qs = rng.uniform(robot.lower, robot.upper, size=(samples, robot.dof))
        scores = np.array([dists(q)[which] for q in qs])
        best = scores.max()
        for idx in np.argsort(scores)[-5:]:
            q, val = qs[idx], scores[idx]
            for sigma in (0.3, 0.1, 0.03, 0.01):
                for _ in range(60):
                    cand = np.clip(q + rng.normal(0, sigma, robot.dof), robot.lower, robot.upper)
                    d = dists(cand)[which]
                    if d > val:
                        q, val = cand, d
            best = max(best, val)
        result.append(float(best))
    robot._reset_arm(saved)
    return result[0], result[1]
