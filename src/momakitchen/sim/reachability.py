"""Base placement by reachability inversion (capability / inverse-reachability maps).

A robot's arm reaches a TCP pose or not whatever the room: which poses it reaches,
relative to its base, is sampled once from its URDF
(:func:`~momakitchen.sim.sampling.sample_grid`) and cached. Inverted at a target's
grasp pose (its height and approach direction), the grid gives every floor point the
answer "could the base stand here, facing the target, and the arm reach it?" and how
far inside the reachable region the pose lies (:meth:`ReachabilityMap.floor_map`).

The grid is over the TCP's distance ``rho`` from the first arm joint's vertical axis,
its height ``z`` above the floor, and its approach direction relative to the radial
direction (yaw ``psi``; pitch below the horizontal, 0 to 90 degrees). Each cell holds
reachable or not, decided by IK at the cell's centre pose; queries between centres read
a signed distance to the region's boundary (metres, positive inside), interpolated
linearly over the four axes: a pose is reachable where it is positive.

Caches: the sampled grid per robot (its URDF and the sampling's parameters, by content
hash) in memory and under ``cache_dir()/reachability``. The arm and its tool are the same
at every mount height (only the pillar changes), so one sampling serves every height:
the map at a mount height is the grid raised to it, TCP poses below the floor removed,
cached in memory per robot and height.
"""

from __future__ import annotations

import hashlib
import io
import json
import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike
from scipy.ndimage import distance_transform_edt, map_coordinates

from momakitchen.errors import MomaError
from momakitchen.sim.sampling import SampledGrid, SamplingConfig

# Bump when the sampling or the meaning of a cell changes: cached grids are then resampled.
MAP_VERSION = 1
# In the reachability index, a class counts fully at a TCP position this far (m) inside
# its reachable region (two cells), less near its boundary, where a few centimetres of
# stop error would lose it.
FULL_SCORE_DEPTH = 0.1
# The score of a reachable floor point is at least this: reachable is score > 0.
MIN_SCORE = 0.01
# The map's sampling when none is given (SamplingConfig's defaults).
DEFAULT_SAMPLING = SamplingConfig()
_SAMPLED: dict[str, SampledGrid] = {}
_MAPS: dict[tuple[str, float, str], ReachabilityMap] = {}


@dataclass(frozen=True)
class ReachabilityMap:
    """Where robot ``robot``'s TCP reaches, relative to its base, at ``mount_height``.

    Attributes:
        robot: registered robot name.
        mount_height: the arm mount's height above the floor (m).
        cell: spacing of the ``rho`` and ``z`` cell centres (m).
        pitches: the pitch classes (degrees below the horizontal, 0 to 90).
        axis_xy: (2,) where the first joint's axis stands, in the base frame (x forward).
        z_first: height above the floor of the first ``z`` cell centre (m).
        reachable: (P, S, R, Z) bool: pitch class, yaw class (``S`` evenly over the
            turn, 0 first: straight away from the axis), ``rho`` cell (centres at
            ``k * cell``), ``z`` cell (centres at ``z_first + l * cell``).
        distance: (P, S, R, Z) signed distance (m) of each cell centre to the boundary of
            the reachable region within its class's (rho, z) plane; derived.
        index: (R, Z) the reachability index of each TCP position (Zacharias et al.):
            the share of the distinct approach classes reachable there, each counted by
            its distance inside its region up to :data:`FULL_SCORE_DEPTH`; derived.
    """

    robot: str
    mount_height: float
    cell: float
    pitches: tuple[float, ...]
    axis_xy: np.ndarray
    z_first: float
    reachable: np.ndarray
    distance: np.ndarray = field(init=False, repr=False, compare=False)
    index: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        grid = np.asarray(self.reachable)
        pitches = tuple(float(v) for v in self.pitches)
        if (
            len(pitches) < 2
            or pitches[0] != 0.0
            or pitches[-1] != 90.0
            or np.any(np.diff(pitches) <= 0)
        ):
            raise MomaError(
                f"ReachabilityMap.pitches must increase from 0 to 90 degrees, got {self.pitches}"
            )
        object.__setattr__(self, "pitches", pitches)
        if grid.dtype != bool or grid.ndim != 4 or grid.shape[0] != len(self.pitches):
            raise MomaError(
                f"ReachabilityMap.reachable must be a (P, S, R, Z) bool grid with P = "
                f"{len(self.pitches)} pitch classes, got {grid.dtype} {grid.shape}"
            )
        if not 0.005 <= self.cell <= 0.5:
            raise MomaError(f"ReachabilityMap.cell must be in [0.005, 0.5] m, got {self.cell}")
        axis = np.asarray(self.axis_xy, np.float64)
        if axis.shape != (2,) or not np.isfinite(axis).all() or not math.isfinite(self.z_first):
            raise MomaError(
                f"ReachabilityMap needs a finite axis_xy (2,) and z_first, got "
                f"{self.axis_xy!r}, {self.z_first!r}"
            )
        if not grid.any():
            raise MomaError(
                f"robot {self.robot!r}: its URDF gives an empty reachability map (no TCP "
                f"pose of the approach classes is reachable at mount height "
                f"{self.mount_height:g} m)"
            )
        object.__setattr__(self, "axis_xy", axis)
        distance = _signed_distance(grid, self.cell)
        depth = np.clip(distance / FULL_SCORE_DEPTH, 0.0, 1.0)
        # a vertical approach has no yaw: its class counts once, not once per yaw
        distinct = depth[:-1].sum(axis=(0, 1)) + depth[-1, 0]
        object.__setattr__(self, "distance", distance)
        object.__setattr__(self, "index", distinct / ((len(self.pitches) - 1) * grid.shape[1] + 1))

    # ------------------------------------------------------------------ building
    @classmethod
    def for_robot(
        cls, robot: str, mount_height: float | None = None, config: SamplingConfig | None = None
    ) -> ReachabilityMap:
        """The map of registered robot ``robot`` (a built-in or a user's) at
        ``mount_height`` (m; default its own), sampled on first use (seconds) and cached
        in memory and on disk (module docstring). MomaError names an unknown robot, a
        mount height outside the allowed range, or a robot whose map is empty."""
        from momakitchen.robots.spec import get_robot_spec
        from momakitchen.robots.urdf import mounted

        spec = get_robot_spec(robot)
        mount = float(mounted(spec, mount_height).mount_height)
        cfg = config if config is not None else DEFAULT_SAMPLING
        key = _digest(robot, cfg)
        if (robot, mount, key) not in _MAPS:
            grid = _sampled(robot, cfg, key)
            z_first = mount + grid.z_first  # the same arm, raised or lowered with its mount
            heights = z_first + np.arange(grid.reachable.shape[3]) * cfg.cell
            # The arm does not reach below the floor, whatever IK says without it.
            reachable = grid.reachable & (heights >= 0.0)
            _MAPS[(robot, mount, key)] = cls(
                robot, mount, cfg.cell, cfg.pitches, grid.axis_xy, float(z_first), reachable
            )
        return _MAPS[(robot, mount, key)]

    # ------------------------------------------------------------------ queries
    def signed_distance(
        self, rho: ArrayLike, z: ArrayLike, psi: ArrayLike, pitch: ArrayLike
    ) -> np.ndarray:
        """How far (m) inside the reachable region a TCP pose lies (negative: outside),
        interpolated between cell centres.

        Shapes:
            - ``rho``, ``z``: (N,) the TCP's distance from the first joint's axis and
              height above the floor (m); ``psi``: (N,) approach yaw from the radial
              direction (rad, any turn); ``pitch``: (N,) approach pitch below the
              horizontal (degrees; clipped to [0, 90]: an approach from below is
              looked up as a horizontal one)
            - output: (N,) float64
        """
        r, h, s, t = (np.asarray(v, np.float64).reshape(-1) for v in (rho, z, psi, pitch))
        n_p, n_s, n_r, n_z = self.distance.shape
        ri = r / self.cell
        zi = (h - self.z_first) / self.cell
        # Beyond the grid the distance keeps growing (the grid's edge cells are outside).
        excess = self.cell * np.hypot(
            np.clip(ri - (n_r - 1), 0, None),
            np.clip(-zi, 0, None) + np.clip(zi - (n_z - 1), 0, None),
        )
        pi_ = np.interp(np.clip(t, 0.0, 90.0), self.pitches, np.arange(n_p))
        si = np.mod(s, 2 * math.pi) / (2 * math.pi / n_s)
        padded = np.concatenate([self.distance, self.distance[:, :1]], axis=1)  # wrap yaw
        coords = np.stack([pi_, si, np.clip(ri, 0, n_r - 1), np.clip(zi, 0, n_z - 1)])
        return map_coordinates(padded, coords, order=1, mode="nearest") - excess

    def reachability_index(self, rho: ArrayLike, z: ArrayLike) -> np.ndarray:
        """The reachability index (:attr:`index`) at TCP positions, interpolated between
        cell centres; 0 beyond the grid.

        Shapes: ``rho``, ``z`` (N,) as in :meth:`signed_distance` -> (N,) in [0, 1]
        """
        r, h = (np.asarray(v, np.float64).reshape(-1) for v in (rho, z))
        coords = np.stack([r / self.cell, (h - self.z_first) / self.cell])
        return map_coordinates(self.index, coords, order=1, mode="constant", cval=0.0)

    def tcp_coordinates(
        self, base_xy: ArrayLike, target_xyz: ArrayLike, approach: ArrayLike | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The target pose as the arm sees it from bases at ``base_xy``, each facing the
        target: ``(rho, z, psi, pitch)`` as :meth:`signed_distance` takes them.

        Shapes:
            - ``base_xy``: (N, 2) floor positions; ``target_xyz``: (3,), or (N, 3) one
              per base, in the same frame (z up, z = 0 on the floor); ``approach``: (3,)
              the TCP's approach
              direction (towards the target) in that frame, or None: horizontal, from
              each base straight towards the target
            - output: four (N,) arrays
        """
        b = np.asarray(base_xy, np.float64).reshape(-1, 2)
        t = np.asarray(target_xyz, np.float64).reshape(-1, 3)
        if len(t) not in (1, len(b)):
            raise MomaError(f"tcp_coordinates: {len(b)} bases but {len(t)} targets")
        to = t[:, :2] - b
        dist = np.hypot(to[:, 0], to[:, 1])
        u = np.where(dist[:, None] > 1e-9, to / np.maximum(dist, 1e-9)[:, None], [1.0, 0.0])
        side = np.column_stack([-u[:, 1], u[:, 0]])
        v = t[:, :2] - (b + self.axis_xy[0] * u + self.axis_xy[1] * side)
        rho = np.hypot(v[:, 0], v[:, 1])
        e_r = np.where(rho[:, None] > 1e-9, v / np.maximum(rho, 1e-9)[:, None], u)
        if approach is None:
            a = np.column_stack([u, np.zeros(len(u))])
        else:
            a = np.broadcast_to(_unit(approach, "approach direction"), (len(b), 3))
        a_r = a[:, 0] * e_r[:, 0] + a[:, 1] * e_r[:, 1]
        a_t = -a[:, 0] * e_r[:, 1] + a[:, 1] * e_r[:, 0]
        pitch = np.degrees(np.arcsin(np.clip(-a[:, 2], -1.0, 1.0)))
        return rho, np.broadcast_to(t[:, 2], len(b)).copy(), np.arctan2(a_t, a_r), pitch

    def reachable_from(
        self, base_xy: ArrayLike, target_xyz: ArrayLike, approach: ArrayLike | None = None
    ) -> np.ndarray:
        """Whether the arm reaches the target pose from bases at ``base_xy`` facing it
        (arguments as :meth:`tcp_coordinates`). Shapes: (N, 2) -> (N,) bool."""
        return self.signed_distance(*self.tcp_coordinates(base_xy, target_xyz, approach)) > 0

    def floor_map(
        self, target_xyz: ArrayLike, approach_dirs: ArrayLike | None, floor_xy: ArrayLike
    ) -> np.ndarray:
        """The inverse-reachability map of a grasp pose over floor points: 0 where a base
        facing the target reaches it by none of the given approaches; elsewhere the
        reachability index of the target's position from there (at least
        :data:`MIN_SCORE`), which prefers bases from which the arm is dexterous over
        ones where it is stretched or folded. Obstacles are not looked at here (see
        :func:`~momakitchen.placement.place`).

        Shapes:
            - ``target_xyz``: (3,) the grasp position; ``approach_dirs``: (A, 3) or (3,)
              approach directions (towards the target), or None: horizontal, from each
              base towards the target; ``floor_xy``: (N, 2) base positions, in the
              frame of ``target_xyz``
            - output: (N,) float64 in [0, 1]
        """
        xy = np.asarray(floor_xy, np.float64).reshape(-1, 2)
        dirs: list[np.ndarray | None] = (
            [None]
            if approach_dirs is None
            else list(np.asarray(approach_dirs, np.float64).reshape(-1, 3))
        )
        if not dirs:
            raise MomaError("floor_map needs at least one approach direction (or None)")
        best = np.full(len(xy), -np.inf)
        for a in dirs:
            rho, z, psi, pitch = self.tcp_coordinates(xy, target_xyz, a)
            best = np.maximum(best, self.signed_distance(rho, z, psi, pitch))
        index = self.reachability_index(rho, z)
        return np.where(best > 0, np.clip(index, MIN_SCORE, 1.0), 0.0)


def _unit(v: ArrayLike, what: str) -> np.ndarray:
    a = np.asarray(v, np.float64).reshape(-1)
    n = float(np.linalg.norm(a)) if a.shape == (3,) else 0.0
    if not (math.isfinite(n) and n > 1e-9):
        raise MomaError(f"the {what} must be a non-zero 3-vector, got {v!r}")
    return a / n


def _signed_distance(grid: np.ndarray, cell: float) -> np.ndarray:
    """Per (pitch, yaw) class: each cell centre's distance (m) to the nearest centre of
    the other kind, less half a cell (so the boundary lies midway), negative outside."""
    out = np.empty(grid.shape, np.float64)
    far = cell * float(np.hypot(*grid.shape[2:]))
    for i in np.ndindex(*grid.shape[:2]):
        inside = grid[i]
        if not inside.any():
            out[i] = -far
        elif inside.all():
            out[i] = far
        else:
            d_in = distance_transform_edt(inside)
            d_out = distance_transform_edt(~inside)
            out[i] = cell * np.where(inside, d_in - 0.5, 0.5 - d_out)
    return out


def _digest(robot: str, cfg: SamplingConfig) -> str:
    """Content key of a robot's sampled grid: its URDF at its own mount (the arm and its
    tool), its home configuration (IK's first seed), the sampling's parameters."""
    from momakitchen.robots.spec import get_robot_spec
    from momakitchen.robots.urdf import robot_urdf

    home = get_robot_spec(robot).model.home
    text = f"{MAP_VERSION}\n{cfg!r}\n{home!r}\n{robot_urdf(robot)}"
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:20]


def _sampled(robot: str, cfg: SamplingConfig, key: str) -> SampledGrid:
    """The robot's grid: from memory, the disk cache, or sampled now (and stored)."""
    from momakitchen.assets.cache import cache_dir
    from momakitchen.fileio import atomic_write_bytes, dumps_strict
    from momakitchen.sim.sampling import sample_grid

    if key in _SAMPLED:
        return _SAMPLED[key]
    path = cache_dir() / "reachability" / f"{robot}-{key}.npz"
    grid = _load(path)
    if grid is None:
        grid = sample_grid(robot, cfg)
        if not grid.reachable.any():
            raise MomaError(
                f"robot {robot!r}: its URDF gives an empty reachability map (no TCP pose "
                "of the approach classes is reachable)"
            )
        buf = io.BytesIO()
        meta = {"robot": robot, "ik_calls": grid.ik_calls, "seconds": grid.seconds}
        np.savez_compressed(
            buf,
            reachable=grid.reachable,
            axis_xy=grid.axis_xy,
            z_first=np.float64(grid.z_first),
            meta=np.array(dumps_strict(meta)),
        )
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_bytes(path, buf.getvalue())
    _SAMPLED[key] = grid
    return grid


def _load(path) -> SampledGrid | None:
    """A cached grid, or None when the file is missing or unreadable (then resampled)."""
    if not path.exists():
        return None
    try:
        with np.load(path, allow_pickle=False) as f:
            meta = json.loads(str(f["meta"]))
            grid = SampledGrid(
                reachable=f["reachable"].astype(bool),
                axis_xy=f["axis_xy"].astype(np.float64),
                z_first=float(f["z_first"]),
                ik_calls=int(meta["ik_calls"]),
                seconds=float(meta["seconds"]),
            )
    except (OSError, ValueError, KeyError, TypeError):
        return None
    if grid.reachable.ndim != 4 or grid.axis_xy.shape != (2,):
        return None
    return grid
