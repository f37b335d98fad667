"""Base motion for the last mile: free space, path planning, and driving with odometry
drift and stop error (docs/APPROACH.md).

The base is holonomic and keeps facing the target while it drives (its head camera stays
on the target, so it can look again anywhere on the way), so a pose is fixed by its
position and the configuration space is the floor itself: a cell is free when the base's
footprint, turned to face the target, fits by the floor plan
(:func:`momakitchen.scene.configuration.base_fits`). The robot knows this free space, as a
robot with a map does; it does not know where the target's good region is.

Paths are shortest paths on the 8-connected grid of free cells (SciPy's Dijkstra,
:func:`scipy.sparse.csgraph.dijkstra`); cells within ``clearance`` of an obstacle cost
``clearance_cost`` times their length, as a costmap's inflation layer makes a planner keep
away from furniture where it can.

Driving follows the planned cells by odometry. Each step's real motion differs from the
commanded one by the odometry motion model of Thrun, Burgard and Fox (*Probabilistic
Robotics*, 2005, sec. 5.4): Gaussian errors whose standard deviation grows with the
distance driven (``drift_along``, ``drift_across``: fractions of the step; ``drift_yaw``:
degrees per metre). The robot believes it followed the plan; the truth drifts away. At
the goal the controller stops with a Gaussian error (``stop_xy`` per axis, ``stop_yaw``)
and the base turns, by odometry, to face where it believes the target is. The defaults
(2 % / 1 % of the distance, 1 deg/m; a 3 cm / 2 deg stop) are those of a calibrated
wheeled base with a docking-grade final controller; Borenstein and Feng (UMBmark, IEEE
T-RA 1996) measured uncalibrated odometry errors of a few per cent of the distance, and
ROS 2 Nav2's goal checkers accept a stop within 0.25 m / 0.25 rad (``SimpleGoalChecker``)
or 0.10 m (``AdaptiveToleranceGoalChecker``'s fine tolerance) by default: the coarse end
of the stop-error sweep.
"""

from __future__ import annotations

import copy
import functools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from momakitchen.errors import MomaError

Pose = tuple[float, float, float]
# Points and poses come as tuples or NumPy arrays.
Vec = Sequence[float] | np.ndarray


@dataclass(frozen=True)
class MotionConfig:
    """How the base drives (lengths in m, angles in degrees, times in s).

    Attributes:
        speed, turn_rate: driving speed (m/s) and turning rate (deg/s).
        look_seconds: fixed cost of a look (stop, settle, capture), besides inference.
        drift_along, drift_across: odometry error, standard deviation as a fraction of
            each step's length, along and across the direction of travel.
        drift_yaw: heading error, standard deviation in degrees per metre driven.
        stop_xy, stop_yaw: final-stop error, standard deviation per axis / of the yaw.
        cell: planning grid (m); ``clearance``, ``clearance_cost``: cells closer than
            ``clearance`` to an obstacle cost this many times their length.
    """

    speed: float = 0.5
    turn_rate: float = 60.0
    look_seconds: float = 1.0
    drift_along: float = 0.02
    drift_across: float = 0.01
    drift_yaw: float = 1.0
    stop_xy: float = 0.03
    stop_yaw: float = 2.0
    cell: float = 0.05
    clearance: float = 0.10
    clearance_cost: float = 3.0

    def __post_init__(self) -> None:
        bounds = {
            "speed": (0.05, 3.0),
            "turn_rate": (5.0, 360.0),
            "look_seconds": (0.0, 60.0),
            "drift_along": (0.0, 0.5),
            "drift_across": (0.0, 0.5),
            "drift_yaw": (0.0, 30.0),
            "stop_xy": (0.0, 0.5),
            "stop_yaw": (0.0, 45.0),
            "cell": (0.02, 0.2),
            "clearance": (0.0, 1.0),
            "clearance_cost": (1.0, 100.0),
        }
        for name, (lo, hi) in bounds.items():
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and lo <= v <= hi):
                raise MomaError(f"MotionConfig.{name} must be in [{lo:g}, {hi:g}], got {v!r}")


class FreeSpace:
    """The floor's free cells for one configuration's base, and shortest paths on them.

    Two layers, as in a navigation costmap (ROS 2 Nav2's static and obstacle layers). The
    static layer is the prior map: the room's walls and floor-standing furniture. The
    configuration's obstacles are in it too by default (``obstacles=True``: the floor
    plan); with ``obstacles=False`` they are not, and enter only through :meth:`observe`,
    as the robot's looks see them.

    Shapes: ``cells`` (N, 2) world xy of every grid cell in the room; ``free`` (N,) bool;
    ``cost`` (N,) per-length cost of the free cells (1, or ``clearance_cost`` near
    obstacles); ``observed`` (N,) bool, the cells :meth:`observe` blocked (or found
    blocked already).
    """

    def __init__(
        self,
        layout: object,
        cfg: object,
        footprint: Sequence[float],
        motion: MotionConfig,
        obstacles: bool = True,
    ):
        from momakitchen.scene.configuration import base_fits

        room = layout.room  # type: ignore[attr-defined]
        self.step = motion.cell
        self.nx = math.floor(room.width / self.step) + 1
        self.ny = math.floor(room.depth / self.step) + 1
        gx, gy = np.meshgrid(np.arange(self.nx), np.arange(self.ny), indexing="ij")
        self.cells = np.round(np.stack([gx.ravel(), gy.ravel()], 1) * self.step, 6)
        length, width = (float(v) for v in footprint)
        grow = 2 * motion.clearance
        self.free, roomy = (
            base_fits(layout, cfg, self.cells, size, include_obstacles=obstacles)  # type: ignore[arg-type]
            for size in ((length, width), (length + grow, width + grow))
        )
        self.cost = np.where(roomy, 1.0, motion.clearance_cost)
        self.observed = np.zeros(len(self.cells), dtype=bool)
        # Each cell's base box as base_fits turns it (facing the target): its axes and
        # half extents (observe grows them by the clearance).
        anchor = cfg.target.anchor  # type: ignore[attr-defined]
        yaws = np.arctan2(anchor[1] - self.cells[:, 1], anchor[0] - self.cells[:, 0])
        self._axes = np.stack([np.cos(yaws), np.sin(yaws)], 1)
        self._half = (length / 2, width / 2)
        self._clearance = motion.clearance
        self._clearance_cost = motion.clearance_cost
        self._graphs = {
            "plan": self._graph(self.cost),
            "length": self._graph(np.ones(len(self.cost))),
        }
        self._trees: dict[tuple[str, int], tuple[np.ndarray, np.ndarray]] = {}

    def _graph(self, cost: np.ndarray) -> object:
        """The 8-connected graph of free cells, edges weighted by length x the mean cost
        of their two cells; a diagonal step may not cut a blocked cell's corner."""
        from scipy.sparse import coo_matrix

        gi, gj = np.meshgrid(np.arange(self.nx), np.arange(self.ny), indexing="ij")
        rows, cols, weights = [], [], []
        for dx, dy in ((1, 0), (0, 1), (1, 1), (1, -1)):
            ok = (gi + dx < self.nx) & (gj + dy >= 0) & (gj + dy < self.ny)
            i, j = gi[ok], gj[ok]
            a, b = i * self.ny + j, (i + dx) * self.ny + j + dy
            both = self.free[a] & self.free[b]
            if dx and dy:
                both &= self.free[(i + dx) * self.ny + j] & self.free[i * self.ny + j + dy]
            a, b = a[both], b[both]
            w = math.hypot(dx, dy) * self.step * 0.5 * (cost[a] + cost[b])
            rows += [a, b]
            cols += [b, a]
            weights += [w, w]
        n = self.nx * self.ny
        return coo_matrix(
            (np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n)
        ).tocsr()

    def copy(self) -> FreeSpace:
        """A copy whose obstacle layer grows apart from this one's (each driven episode
        starts from the same prior map); the arrays are shared until :meth:`observe`
        replaces them, the graphs until then too."""
        other = copy.copy(self)
        other._graphs = dict(self._graphs)
        other._trees = {}
        return other

    def observe(self, points_xy: np.ndarray) -> bool:
        """Add obstacle points to the obstacle layer: every cell whose base box (centred
        on the cell, facing the target, as :func:`~momakitchen.scene.configuration.base_fits`
        turns it) contains a point becomes blocked, and every cell whose box grown by the
        clearance on each side contains one costs ``clearance_cost``. Points on a box's
        edge count as outside, as touching boxes count as apart in ``base_fits``. The
        graphs are rebuilt, and planned trees dropped, only when a free cell is blocked or
        costs more.

        Returns whether a free cell became blocked (a planned path may cross it: plan
        again). Shapes: ``points_xy`` (M, 2) xy in the cells' frame (the world, or the
        odometry frame the robot plans in) of points above the floor; non-finite rows are
        skipped.
        """
        pts = np.asarray(points_xy, np.float64).reshape(-1, 2)
        hit, near = self._boxes_containing(pts[np.isfinite(pts).all(1)])
        self.observed |= hit
        blocked = hit & self.free
        free = self.free & ~hit
        costlier = near & (self.cost != self._clearance_cost)
        if not (blocked.any() or (costlier & free).any()):
            return False
        self.free = free
        self.cost = np.where(near, self._clearance_cost, self.cost)
        self._graphs["plan"] = self._graph(self.cost)
        if blocked.any():
            self._graphs["length"] = self._graph(np.ones(len(self.cost)))
        self._trees.clear()
        self.__dict__.pop("components", None)  # the cached property, made again on use
        return bool(blocked.any())

    def _boxes_containing(self, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(N,) bool twice: the cells whose base box contains one of ``pts`` (K, 2), and
        those whose box grown by the clearance does. Each point is tested against the
        cells within the grown box's half-diagonal of it (a disc of grid offsets around
        its nearest cell), in the cell's own box frame."""
        hit = np.zeros(len(self.cells), dtype=bool)
        near = np.zeros(len(self.cells), dtype=bool)
        hl, hw = self._half
        g = self._clearance
        reach = math.hypot(hl + g, hw + g) / self.step + 1.0  # a point is < 1 cell off its cell
        k = math.ceil(reach)
        di, dj = np.meshgrid(np.arange(-k, k + 1), np.arange(-k, k + 1), indexing="ij")
        disc = np.hypot(di, dj) <= reach
        di, dj = di[disc], dj[disc]
        chunk = max(1, 400_000 // len(di))
        for lo in range(0, len(pts), chunk):
            p = pts[lo : lo + chunk]
            i = np.rint(p[:, 0] / self.step).astype(np.int64)[:, None] + di
            j = np.rint(p[:, 1] / self.step).astype(np.int64)[:, None] + dj
            inside = (i >= 0) & (i < self.nx) & (j >= 0) & (j < self.ny)
            cell = (i * self.ny + j)[inside]
            dx = np.broadcast_to(p[:, :1], i.shape)[inside] - self.cells[cell, 0]
            dy = np.broadcast_to(p[:, 1:], i.shape)[inside] - self.cells[cell, 1]
            c, s = self._axes[cell, 0], self._axes[cell, 1]
            u = np.abs(c * dx + s * dy)  # along the base's facing direction
            v = np.abs(c * dy - s * dx)  # across it
            grown = (u < hl + g) & (v < hw + g)
            near[cell[grown]] = True
            hit[cell[grown & (u < hl) & (v < hw)]] = True
        return hit, near

    def index(self, x: float, y: float) -> int:
        """The cell nearest to (x, y), clamped to the room."""
        i = min(max(round(x / self.step), 0), self.nx - 1)
        j = min(max(round(y / self.step), 0), self.ny - 1)
        return int(i * self.ny + j)

    def is_free(self, x: float, y: float) -> bool:
        return bool(self.free[self.index(x, y)])

    def _tree(
        self, start_xy: Sequence[float], graph: str = "plan"
    ) -> tuple[np.ndarray, np.ndarray]:
        from scipy.sparse.csgraph import dijkstra

        key = (graph, self.index(*start_xy))
        if key not in self._trees:
            if len(self._trees) > 8:  # a few starts per configuration at most
                self._trees.clear()
            dist, pred = dijkstra(self._graphs[graph], indices=key[1], return_predecessors=True)
            self._trees[key] = (dist, pred)
        return self._trees[key]

    def reachable(self, start_xy: Sequence[float]) -> Callable[[float, float], bool]:
        """``f(x, y)``: whether the cell of (x, y) is free and connected to ``start_xy``."""
        dist = self._tree(start_xy)[0]
        return lambda x, y: bool(np.isfinite(dist[self.index(x, y)]))

    @functools.cached_property
    def components(self) -> np.ndarray:
        """The connected piece of free floor each cell belongs to (blocked cells are
        pieces of their own): two free cells are connected iff their labels are equal.
        Shapes: (N,) int, indexed as ``cells``."""
        from scipy.sparse.csgraph import connected_components

        return connected_components(self._graphs["plan"], directed=False)[1]

    def shortest(self, start_xy: Sequence[float]) -> np.ndarray:
        """Length (m) of the shortest collision-free grid path from ``start_xy`` to every
        cell (inf where none), without the planner's clearance costs. Shapes: (N,),
        indexed as ``cells``."""
        return self._tree(start_xy, "length")[0]

    def plan(self, start_xy: Sequence[float], goal_xy: Sequence[float]) -> np.ndarray | None:
        """Waypoints (K, 2): the exact start, the cells of the planned path between, the
        exact goal; None when the goal's cell is not reachable from the start's."""
        start, goal = self.index(*start_xy), self.index(*goal_xy)
        dist, pred = self._tree(start_xy)
        if not np.isfinite(dist[goal]):
            return None
        chain = [goal]
        while chain[-1] != start:
            chain.append(int(pred[chain[-1]]))
        inner = self.cells[chain[::-1]][1:-1]
        ends = np.asarray([start_xy, goal_xy], float)
        return np.vstack([ends[:1], inner, ends[1:]])


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


@dataclass
class BaseState:
    """Where the base really is (``true``) and where odometry says it is (``odom``),
    both (x, y, yaw) in the world; the odometry frame is the world at the start."""

    true: Pose
    odom: Pose
    driven: float = 0.0  # m, along the true path
    turned: float = 0.0  # rad, every turn
    odom_trace: list[Pose] = field(default_factory=list)  # every step's odometry pose

    def trace(self) -> list[list[float]]:
        return [[round(v, 4) for v in self.true], [round(v, 4) for v in self.odom]]


def face(xy: Vec, target: Vec) -> float:
    return math.atan2(target[1] - xy[1], target[0] - xy[0])


def drive(
    state: BaseState,
    waypoints: np.ndarray,
    target_xy: Vec,
    motion: MotionConfig,
    rng: np.random.Generator,
    check: Callable[[Pose], bool] | None = None,
    stop_after: float = math.inf,
) -> tuple[list[Pose], bool]:
    """Drive ``state`` along ``waypoints`` (odometry frame) facing ``target_xy`` (odometry
    frame), with odometry drift; stops after ``stop_after`` m of driving or at the end.

    ``check(true_pose)`` is called before every step and returns False if the base would
    collide there (PyBullet); the base then stops where it is. Returns the true poses
    visited and whether the drive ended without being blocked. ``state`` is updated in place.

    Shapes: ``waypoints`` (K, 2).
    """
    poses: list[Pose] = [state.true]
    travelled = 0.0
    for w in waypoints[1:]:
        ox, oy, oyaw = state.odom
        d = np.asarray(w, float) - (ox, oy)
        length = float(np.hypot(*d))
        if length < 1e-9:
            continue
        # Sub-steps of at most half a cell, so collisions between waypoints are seen.
        n = max(1, math.ceil(length / (0.5 * motion.cell)))
        for _ in range(n):
            if travelled >= stop_after:
                return poses, True
            ox, oy, oyaw = state.odom
            step = d / n
            new_odom_xy = (ox + step[0], oy + step[1])
            new_odom_yaw = face(new_odom_xy, target_xy)
            # The commanded motion in the base frame at the odometry pose ...
            c, s = math.cos(oyaw), math.sin(oyaw)
            local = np.array([c * step[0] + s * step[1], -s * step[0] + c * step[1]])
            dyaw = _wrap(new_odom_yaw - oyaw)
            ds = length / n
            # ... executed with errors along / across the direction of travel and in yaw.
            heading = math.atan2(local[1], local[0])
            along = ds * (1 + motion.drift_along * rng.standard_normal())
            across = ds * motion.drift_across * rng.standard_normal()
            yaw_err = math.radians(motion.drift_yaw) * ds * rng.standard_normal()
            real = np.array(
                [
                    along * math.cos(heading) - across * math.sin(heading),
                    along * math.sin(heading) + across * math.cos(heading),
                ]
            )
            tx, ty, tyaw = state.true
            ct, st = math.cos(tyaw), math.sin(tyaw)
            true = (
                tx + ct * real[0] - st * real[1],
                ty + st * real[0] + ct * real[1],
                _wrap(tyaw + dyaw + yaw_err),
            )
            if check is not None and not check(true):
                return poses, False  # the base stops before the contact
            state.true = true
            state.odom = (new_odom_xy[0], new_odom_xy[1], new_odom_yaw)
            state.odom_trace.append(state.odom)
            state.driven += float(np.hypot(*real))
            state.turned += abs(dyaw)
            travelled += ds
            poses.append(state.true)
    return poses, True


def stop_and_face(
    state: BaseState,
    target_odom: Vec,
    sigma_xy: float,
    sigma_yaw: float,
    noise: Vec,
) -> Pose:
    """The controller stops with an error, then the base turns by odometry to face
    ``target_odom``; returns the true final pose (``state`` is not changed).

    ``noise``: three standard normal numbers (x, y, yaw) drawn once per episode, scaled by
    ``sigma_xy`` (m) and ``sigma_yaw`` (deg), so that one draw serves a stop-error sweep.
    """
    ox, oy, oyaw = state.odom
    turn = _wrap(face((ox, oy), target_odom) - oyaw)
    tx, ty, tyaw = state.true
    return (
        tx + sigma_xy * noise[0],
        ty + sigma_xy * noise[1],
        _wrap(tyaw + turn + math.radians(sigma_yaw) * noise[2]),
    )
