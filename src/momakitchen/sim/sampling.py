"""A robot's reachability sampled from its URDF: which TCP poses its arm can take.

The grid is over TCP poses relative to the first arm joint's (vertical) axis: radius
``rho`` from the axis, height ``z``, and the approach direction (the TCP's z axis) in the
radial frame (x away from the axis, z up): a yaw ``psi`` about the vertical (0: straight
away from the base) and a pitch class below the horizontal (0: horizontal, 90: top-down).
Turning the first joint turns every pose about the axis, so one azimuth is enough: a base
facing its target holds the target at azimuth 0.

Two passes, as the capability maps of Zacharias et al. (2007) and Vahrenkamp et al.
(2013): random joint configurations by forward kinematics (each turned by the first
joint so that its TCP lies at azimuth 0) say which cells the arm comes near with about
the right approach; inverse kinematics (:func:`momakitchen.robots.ik.solve_ik`, seeded
with the nearest such configuration) then decides each of those cells at its exact
centre pose. Cells no configuration comes near are unreachable without IK; so are cells
outside the workspace spheres, which IK itself rejects first.
"""

from __future__ import annotations

import itertools
import math
import time
from collections import deque
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import binary_dilation
from scipy.spatial import cKDTree

from momakitchen.errors import MomaError

# IK restarts for a cell that two or more reachable neighbours surround.
HOLE_RESTARTS = 3


@dataclass(frozen=True)
class SamplingConfig:
    """How a reachability grid is sampled (metres, degrees).

    Attributes:
        cell: spacing of the ``rho`` and ``z`` cell centres.
        psi_bins: approach yaw classes, evenly over the full turn (``360 / psi_bins`` apart).
        pitches: approach pitch classes, degrees below the horizontal, increasing from 0
            (horizontal) to 90 (top-down; one class whatever the yaw).
        fk_samples: random joint configurations of the first pass.
        support_angle: a configuration supports a class's cells (its own and its
            neighbours) when its approach is within this angle of the class's.
        seed: of the random configurations.
    """

    cell: float = 0.05
    psi_bins: int = 12
    pitches: tuple[float, ...] = (0.0, 45.0, 90.0)
    fk_samples: int = 20000
    support_angle: float = 25.0
    seed: int = 0

    def __post_init__(self) -> None:
        if not 0.01 <= self.cell <= 0.2:
            raise MomaError(f"SamplingConfig.cell must be in [0.01, 0.2] m, got {self.cell}")
        if not 4 <= self.psi_bins <= 72:
            raise MomaError(f"SamplingConfig.psi_bins must be in [4, 72], got {self.psi_bins}")
        pitches = tuple(float(v) for v in self.pitches)
        if (
            len(pitches) < 2
            or pitches[0] != 0.0
            or pitches[-1] != 90.0
            or any(b <= a for a, b in itertools.pairwise(pitches))
        ):
            raise MomaError(
                f"SamplingConfig.pitches must increase from 0 to 90 degrees, got {self.pitches}"
            )
        object.__setattr__(self, "pitches", pitches)
        if not 1000 <= self.fk_samples <= 1_000_000:
            raise MomaError(
                f"SamplingConfig.fk_samples must be in [1000, 1e6], got {self.fk_samples}"
            )
        if not 5.0 <= self.support_angle <= 90.0:
            raise MomaError(
                f"SamplingConfig.support_angle must be in [5, 90] deg, got {self.support_angle}"
            )

    def psis(self) -> np.ndarray:
        """The approach yaw classes (radians), shape ``(psi_bins,)``: 0 first."""
        return np.arange(self.psi_bins) * (2 * math.pi / self.psi_bins)


@dataclass(frozen=True)
class SampledGrid:
    """The outcome of :func:`sample_grid` for a robot at its own mount height.

    Attributes:
        reachable: (P, S, R, Z) bool: pitch class, yaw class, ``rho`` cell, ``z`` cell.
        axis_xy: (2,) where the first joint's axis meets the floor, in the base frame.
        z_first: height of the first ``z`` cell centre above the arm mount (m).
        ik_calls: IK solves the second pass made.
        seconds: wall time of the sampling.
    """

    reachable: np.ndarray
    axis_xy: np.ndarray
    z_first: float
    ik_calls: int
    seconds: float


def class_directions(pitch_deg: float, psis: np.ndarray) -> np.ndarray:
    """Unit approach directions in the radial frame (x away from the axis, z up) of one
    pitch class and the yaws ``psis`` (radians). Shapes: ``psis`` (S,) -> (S, 3)."""
    pitch = math.radians(pitch_deg)
    return np.column_stack(
        [
            math.cos(pitch) * np.cos(psis),
            math.cos(pitch) * np.sin(psis),
            np.full(len(psis), -math.sin(pitch)),
        ]
    )


def approach_quaternion(direction: np.ndarray, radial: np.ndarray) -> np.ndarray:
    """The TCP orientation ``(x, y, z, w)`` of an approach (the TCP's z axis along
    ``direction``), its roll fixed: the fingers close horizontally, across the approach,
    or for a vertical approach across ``radial`` (a horizontal unit vector away from the
    axis). Rotating both inputs about the vertical rotates the result with them."""
    from momakitchen.sim.trials import tcp_quaternion

    z = np.asarray(direction, np.float64)
    across = np.array([-z[1], z[0], 0.0])
    if float(np.hypot(z[0], z[1])) < 1e-6:
        across = np.array([-radial[1], radial[0], 0.0])
    return tcp_quaternion(-z, across)


def _first_axis(robot) -> float:
    """+1 or -1: the first arm joint turns about +z or -z of the base. MomaError naming
    the robot when it is not a revolute joint about a vertical axis (the map's symmetry)."""
    from momakitchen.bullet import p

    joint = robot.arm_joints[0]
    info = p.getJointInfo(robot.body, joint, physicsClientId=robot.client)
    _, orn = robot.link_pose(joint)  # the joint's axis is given in its child link's frame
    axis = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3) @ np.asarray(info[13])
    if info[2] != p.JOINT_REVOLUTE or abs(float(axis[2])) < math.cos(math.radians(1.0)):
        raise MomaError(
            f"robot {robot.name!r}: its first arm joint does not turn about a vertical axis, "
            "which the reachability map needs"
        )
    return 1.0 if axis[2] > 0 else -1.0


def _fk_samples(
    robot, sign: float, centre: np.ndarray, n: int, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Random configurations turned by the first joint so that the TCP lies at azimuth
    0 about the axis (those whose turn the joint's limits forbid are dropped): the
    configurations (M, dof), the TCP's ``rho`` and ``z`` (M,) and its approach in the
    radial frame (M, 3)."""
    from momakitchen.bullet import p

    qs = rng.uniform(robot.lower, robot.upper, size=(n, robot.dof))
    qs[:, 0] = 0.0
    pos, zax = np.empty((n, 3)), np.empty((n, 3))
    for i, q in enumerate(qs):
        # A kinematic reset, as IK does (set_joint_positions also drives the motors, and
        # nothing steps physics here): FK only.
        robot._reset_arm(q)
        st = p.getLinkState(
            robot.body, robot.tcp_link, computeForwardKinematics=True, physicsClientId=robot.client
        )
        pos[i] = st[4]
        zax[i] = np.array(p.getMatrixFromQuaternion(st[5]))[2::3]
    rel = pos[:, :2] - centre[:2]
    phi = np.arctan2(rel[:, 1], rel[:, 0])
    # The joint turns the TCP by sign * q1: q1 = -sign * phi brings it to azimuth 0.
    q1 = -sign * phi
    ok = (q1 >= robot.lower[0]) & (q1 <= robot.upper[0])
    alt = q1 - np.sign(q1) * 2 * math.pi  # the same turn the other way round
    use_alt = ~ok & (alt >= robot.lower[0]) & (alt <= robot.upper[0])
    q1 = np.where(use_alt, alt, q1)
    keep = ok | use_alt
    qs[:, 0] = q1
    c, s = np.cos(-phi), np.sin(-phi)
    radial = np.column_stack(
        [c * zax[:, 0] - s * zax[:, 1], s * zax[:, 0] + c * zax[:, 1], zax[:, 2]]
    )
    rho = np.hypot(rel[:, 0], rel[:, 1])
    return qs[keep], rho[keep], pos[keep, 2], radial[keep]


def sample_grid(name: str, config: SamplingConfig | None = None) -> SampledGrid:
    """The reachability grid of registered robot ``name`` at its own mount height,
    sampled in a scratch PyBullet client of its own (module docstring)."""
    from momakitchen.bullet import connect_direct, p
    from momakitchen.robots.reach import within_reach
    from momakitchen.robots.robot import Robot

    cfg = config if config is not None else SamplingConfig()
    t0 = time.perf_counter()
    client = connect_direct()
    try:
        robot = Robot(client, name)
        sign = _first_axis(robot)
        geometry = robot.reach_geometry
        centre = np.asarray(geometry.centre, np.float64)
        rng = np.random.default_rng(cfg.seed)
        qs, rho, z, appr = _fk_samples(robot, sign, centre, cfg.fk_samples, rng)
        span = robot.workspace()[1] + geometry.shoulder_offset + cfg.cell
        n_rho = math.ceil(span / cfg.cell) + 1
        half = math.ceil(span / cfg.cell)
        rho_c = np.arange(n_rho) * cfg.cell
        z_c = centre[2] + np.arange(-half, half + 1) * cfg.cell
        # Nearest configurations by TCP position, then approach (as the IK library does).
        tree = cKDTree(np.column_stack([rho, z, 0.15 * appr]))
        cos_tol = math.cos(math.radians(cfg.support_angle))
        ri = np.clip(np.rint(rho / cfg.cell).astype(np.int64), 0, n_rho - 1)
        zi = np.clip(np.rint((z - z_c[0]) / cfg.cell).astype(np.int64), 0, len(z_c) - 1)
        grid = np.zeros((len(cfg.pitches), cfg.psi_bins, n_rho, len(z_c)), bool)
        calls = 0
        for pi_, pitch in enumerate(cfg.pitches):
            psis = cfg.psis()[:1] if pitch == 90.0 else cfg.psis()
            for si, d in enumerate(class_directions(pitch, psis)):
                near = appr @ d >= cos_tol
                support = np.zeros((n_rho, len(z_c)), bool)
                support[ri[near], zi[near]] = True
                support = binary_dilation(support, np.ones((3, 3), bool))
                quat = approach_quaternion(d, np.array([1.0, 0.0]))
                rot = np.array(p.getMatrixFromQuaternion(quat.tolist())).reshape(3, 3)
                cand = np.zeros_like(support)
                for k, j in zip(*np.nonzero(support), strict=True):
                    pos = np.array([centre[0] + rho_c[k], centre[1], z_c[j]])
                    cand[k, j] = within_reach(robot, pos, rot, 0.015)
                grid[pi_, si], n = _solve_class(
                    robot,
                    cand,
                    lambda k, j, q=quat: (np.array([centre[0] + rho_c[k], centre[1], z_c[j]]), q),
                    lambda k, j, d=d: qs[tree.query(np.r_[rho_c[k], z_c[j], 0.15 * d])[1]],
                )
                calls += n
            if pitch == 90.0:  # a vertical approach has no yaw
                grid[pi_] = grid[pi_, :1]
    finally:
        p.disconnect(client)
    return SampledGrid(
        reachable=grid,
        axis_xy=centre[:2].copy(),
        z_first=float(z_c[0] - robot.mount_height),
        ik_calls=calls,
        seconds=time.perf_counter() - t0,
    )


def _solve_class(robot, cand: np.ndarray, pose_of, fk_seed) -> tuple[np.ndarray, int]:
    """Decide the candidate cells (R, Z) of one class by IK at their centre poses. A
    solved neighbour's joints are the best seed (a few iterations away), so the solved
    region grows from cell to cell; the nearest sampled configuration is the other seed.
    Each cell gets at most three solves; IK's restarts are left to the query side.
    Returns the reachable cells (R, Z) and the solves made."""
    from momakitchen.robots.ik import solve_ik

    out = np.zeros_like(cand)
    solution: dict[tuple[int, int], np.ndarray] = {}
    fk_tried, nb_tried = np.zeros_like(cand), np.zeros_like(cand)
    queue = deque(zip(*np.nonzero(cand), strict=True))
    calls = 0
    while queue:
        cell = queue.popleft()
        if out[cell]:
            continue
        k, j = cell
        around = [(k - 1, j), (k + 1, j), (k, j - 1), (k, j + 1)]
        seeds = []
        if not nb_tried[cell]:
            seeds = [solution[n] for n in around if n in solution][:2]
            nb_tried[cell] = bool(seeds)
        if not fk_tried[cell]:
            seeds.append(fk_seed(k, j))
            fk_tried[cell] = True
        pos, quat = pose_of(k, j)
        for seed in seeds:
            calls += 1
            res = solve_ik(robot, pos, quat, seed=seed, restarts=0)
            if res.success:
                out[cell], solution[cell] = True, res.q
                break
        if out[cell]:  # its neighbours may now start from here
            queue.extendleft(
                n
                for n in around
                if 0 <= n[0] < cand.shape[0]
                and 0 <= n[1] < cand.shape[1]
                and cand[n]
                and not out[n]
                and not nb_tried[n]
            )
    # A cell most of whose neighbours are reachable is most likely reachable too: it gets
    # IK's restarts (home, the library's nearest configurations) before it counts as a hole.
    for cell in zip(*np.nonzero(cand & ~out), strict=True):
        k, j = cell
        solved = [
            solution[n] for n in ((k - 1, j), (k + 1, j), (k, j - 1), (k, j + 1)) if n in solution
        ]
        if len(solved) >= 2:
            pos, quat = pose_of(k, j)
            calls += 1
            res = solve_ik(robot, pos, quat, seed=solved[0], restarts=HOLE_RESTARTS)
            out[cell] = res.success
    return out, calls
