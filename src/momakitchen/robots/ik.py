"""Inverse kinematics of a :class:`~momakitchen.robots.robot.Robot`.

Damped least squares (Levenberg-Marquardt) on PyBullet's forward kinematics, with
restarts: from the seed, from home, then from the nearest poses of a per-robot library of
sampled configurations (:data:`SEED_LIBRARY`). ``Robot.solve_ik`` and ``Robot.plan_line``
call these functions; conventions as in ``robot.py`` (joint vectors ``(dof,)``, positions
``(3,)``, quaternions ``(x, y, z, w)``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from momakitchen.bullet import p
from momakitchen.errors import MomaError
from momakitchen.robots import collisions
from momakitchen.robots.body import RobotBody
from momakitchen.robots.reach import within_reach

# Per process and robot name: (configurations (n, dof), TCP positions (n, 3), TCP z axes
# (n, 3)) in the base frame of the robot at its own mount height (the same for any height,
# shifted by it). Filled by ``build_seed_library`` (warmed in a scratch client).
SEED_LIBRARY: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
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


_LEVI_CIVITA = np.zeros((3, 3, 3))
_LEVI_CIVITA[0, 1, 2] = _LEVI_CIVITA[1, 2, 0] = _LEVI_CIVITA[2, 0, 1] = 1.0
_LEVI_CIVITA[0, 2, 1] = _LEVI_CIVITA[2, 1, 0] = _LEVI_CIVITA[1, 0, 2] = -1.0


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross product, ``(n, 3) x (n, 3) or (3,) -> (n, 3)`` (np.cross is several
    times slower at this size, and IK calls this thousands of times)."""
    if b.ndim == 1:
        return np.einsum("ijk,nj,k->ni", _LEVI_CIVITA, a, b)
    return np.einsum("ijk,nj,nk->ni", _LEVI_CIVITA, a, b)


def _ik_target(
    position: ArrayLike, orientation: ArrayLike | None
) -> tuple[np.ndarray, np.ndarray | None]:
    """The checked IK goal: position (3,) and rotation matrix (3, 3) or None."""
    target = np.asarray(position, float)
    if target.shape != (3,) or not np.all(np.isfinite(target)):
        raise MomaError(f"IK position must be 3 finite numbers, got {position!r}")
    if orientation is None:
        return target, None
    quat = np.asarray(orientation, float)
    norm = float(np.linalg.norm(quat)) if quat.shape == (4,) else 0.0
    if not 0.5 < norm < 2.0:
        raise MomaError(f"IK orientation must be a unit quaternion, got {orientation!r}")
    return target, np.array(p.getMatrixFromQuaternion((quat / norm).tolist())).reshape(3, 3)


def solve_ik(
    robot: RobotBody,
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
    target, target_rot = _ik_target(position, orientation)
    rng = rng if rng is not None else np.random.default_rng(0)
    slack = pos_tol + 0.01  # the sampled workspace radii may fall a little short
    if not within_reach(robot, target, target_rot, slack):
        # Outside the workspace sphere: no configuration can do it.
        pos, cur = robot.tcp_pose()
        oerr = 0.0
        if target_rot is not None:
            rot = np.array(p.getMatrixFromQuaternion(cur)).reshape(3, 3)
            oerr = math.acos(min(1.0, max(-1.0, (np.trace(target_rot @ rot.T) - 1) / 2)))
        return IKResult(
            q=robot.joint_positions(),
            position_error=float(np.linalg.norm(pos - target)),
            orientation_error=oerr,
            success=False,
            calls=0,
            seconds=time.perf_counter() - t0,
        )
    seeds = [np.asarray(seed if seed is not None else robot.joint_positions(), float), robot.home]
    best: tuple[float, float, np.ndarray] | None = None
    calls = 0
    for attempt in range(restarts + 1):
        if attempt == 2:  # the easy seeds failed: look up the library (built lazily)
            seeds += _library_seeds(robot, target, target_rot, restarts - 1)
        q0 = seeds[attempt] if attempt < len(seeds) else rng.uniform(robot.lower, robot.upper)
        q, perr, oerr, n = _lm(robot, q0, target, target_rot, iterations, pos_tol, ori_tol)
        calls += n
        if best is None or perr + 0.1 * oerr < best[0] + 0.1 * best[1]:
            best = (perr, oerr, q)
        if perr <= pos_tol and oerr <= ori_tol:
            break
    assert best is not None  # at least one attempt ran
    perr, oerr, q = best
    robot._reset_arm(q)
    return IKResult(
        q=q,
        position_error=perr,
        orientation_error=oerr,
        success=perr <= pos_tol and oerr <= ori_tol,
        calls=calls,
        seconds=time.perf_counter() - t0,
    )


def ik_solutions(
    robot: RobotBody,
    position: ArrayLike,
    orientation: ArrayLike | None,
    *,
    starts: int = 6,
    pos_tol: float = 0.005,
    ori_tol: float = math.radians(2.0),
    iterations: int = 40,
    distinct: float = 0.3,
) -> Iterator[IKResult]:
    """Converged IK solutions of one pose from different starts, in a fixed order: from
    home, then from the ``starts - 1`` library configurations nearest the pose. Solutions
    within ``distinct`` rad (every joint) of one already given are skipped, so a caller
    that rejects a solution (it collides) gets another arm configuration: elbow or wrist
    flipped, the arm turned another way. The arm is left at the last solution tried.
    """
    target, target_rot = _ik_target(position, orientation)
    if not within_reach(robot, target, target_rot, pos_tol + 0.01):
        return
    seen: list[np.ndarray] = []
    seeds = [robot.home]
    for k in range(starts):
        if k == 1:  # home did not do: the library's nearest configurations (built lazily)
            seeds += _library_seeds(robot, target, target_rot, starts - 1)
        if k >= len(seeds):
            break
        t0 = time.perf_counter()
        q, perr, oerr, n = _lm(robot, seeds[k], target, target_rot, iterations, pos_tol, ori_tol)
        if perr > pos_tol or oerr > ori_tol:
            continue
        if any(float(np.max(np.abs(q - s))) < distinct for s in seen):
            continue
        seen.append(q)
        robot._reset_arm(q)
        yield IKResult(q, perr, oerr, True, n, time.perf_counter() - t0)


def _library_seeds(
    robot: RobotBody, target: np.ndarray, target_rot: np.ndarray | None, k: int
) -> list[np.ndarray]:
    """The ``k`` configurations of a sampled library whose TCP pose is nearest the
    target (in the base frame): far better restarts than uniform random ones."""
    if k <= 0:
        return []
    if robot.name not in SEED_LIBRARY:
        SEED_LIBRARY[robot.name] = build_seed_library(robot)
    qs, pos, zax = SEED_LIBRARY[robot.name]
    bpos, born = p.getBasePositionAndOrientation(robot.body, physicsClientId=robot.client)
    brot = np.array(p.getMatrixFromQuaternion(born)).reshape(3, 3)
    local = brot.T @ (target - np.array(bpos))
    if robot.mount_shift:  # the library is in the frame of the robot at its own height
        local = local - np.array([0.0, 0.0, robot.mount_shift])
    dist = np.linalg.norm(pos - local, axis=1)
    if target_rot is not None:
        # Approach direction matters most for the wrist: compare the TCP z axes.
        dist = dist + 0.15 * np.linalg.norm(zax - brot.T @ target_rot[:, 2], axis=1)
    return list(qs[np.argsort(dist)[:k]])


def build_seed_library(
    robot: RobotBody, n: int = 1500
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Random configurations free of self-collision, with their TCP position and z axis in
    the base frame. A seed that folds the arm into its own base leads IK to solutions that
    do the same: such seeds are drawn again (at most 5 rounds)."""
    rng = np.random.default_rng(1)
    saved = robot.joint_positions()
    bpos, born = p.getBasePositionAndOrientation(robot.body, physicsClientId=robot.client)
    brot = np.array(p.getMatrixFromQuaternion(born)).reshape(3, 3)
    free: list[np.ndarray] = []
    for _round in range(5):
        for q in rng.uniform(robot.lower, robot.upper, size=(n, robot.dof)):
            robot._reset_arm(q)
            if not collisions.arm_collisions(robot, ()):
                free.append(q)
        if len(free) >= n:
            break
    qs = np.array(free[:n])
    pos, zax = np.empty((len(qs), 3)), np.empty((len(qs), 3))
    for i, q in enumerate(qs):
        robot._reset_arm(q)
        wp, wq = robot.link_pose(robot.tcp_link)
        pos[i] = brot.T @ (wp - np.array(bpos)) - np.array([0.0, 0.0, robot.mount_shift])
        zax[i] = brot.T @ np.array(p.getMatrixFromQuaternion(wq)).reshape(3, 3)[:, 2]
    robot._reset_arm(saved)
    return qs, pos, zax


def _lm(
    robot: RobotBody,
    q: np.ndarray,
    target: np.ndarray,
    target_rot: np.ndarray | None,
    iterations: int,
    pos_tol: float,
    ori_tol: float,
) -> tuple[np.ndarray, float, float, int]:
    """Levenberg-Marquardt from ``q``; returns ``(q, pos err, ori err, iterations)``.

    The geometric Jacobian is assembled from the joint frames (one getLinkStates
    call): PyBullet's calculateJacobian is off by up to ~1 cm/rad on these models.
    """
    c = robot.client
    q = np.clip(q, robot.lower, robot.upper)
    links = [*robot.arm_joints, robot.tcp_link]
    axes_local = robot._axes_local
    lam = 1e-4
    prev = math.inf
    last_gain = 0
    perr = oerr = math.inf
    for it in range(iterations + 1):
        robot._reset_arm(q)
        states = p.getLinkStates(
            robot.body, links, computeForwardKinematics=True, physicsClientId=c
        )
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
        jv = np.where(robot._prismatic[:, None], axes, _cross(axes, tcp_pos - pos))
        if target_rot is not None:
            vee = np.array(
                [r_err[2, 1] - r_err[1, 2], r_err[0, 2] - r_err[2, 0], r_err[1, 0] - r_err[0, 1]]
            )
            sin = math.sin(oerr)
            e_rot = vee * (oerr / (2 * sin) if sin > 1e-6 else 0.5)
            if oerr > 3.0:  # the vee map vanishes near pi: push about the tool's x axis
                e_rot = e_rot + 0.5 * rot[:, 0]
            jw = np.where(robot._prismatic[:, None], 0.0, axes)
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
        q = np.clip(q + dq, robot.lower, robot.upper)
    return q, perr, oerr, iterations


def plan_line(
    robot: RobotBody, position: ArrayLike, orientation: ArrayLike | None, n: int = 10
) -> list[np.ndarray] | None:
    """IK waypoints moving the TCP on a straight line to a pose, or None if any fails.

    The physical joint state (positions and velocities) is left untouched.
    """
    start, _ = robot.tcp_pose()
    goal = np.asarray(position, float)
    path, q = [], robot.joint_positions()
    with robot.kinematic_scratch():
        for k in range(1, n + 1):
            res = solve_ik(robot, start + (goal - start) * k / n, orientation, seed=q, restarts=0)
            if not res.success:
                return None
            q = res.q
            path.append(q)
    return path
