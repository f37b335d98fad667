"""Configurations: a scene plus objects on the counter, one target, obstacles and a robot.

Pure data, fully determined by ``(scene_id, index)`` and the :class:`SceneConfig`. A
configuration's target is either a rigid object standing on the countertop or the
functional part (door, drawer, lever) of an articulated furniture unit. Obstacles stand
inside the sampling semicircle in front of the target, whose radius is the robot's reach;
some of them may stand where a base would naturally stop (``SceneConfig.stance_obstacles``).
The robot's arm stands at its own mount height, or at one drawn for the configuration
(:func:`configuration_mount`) when the config or the robot gives a range.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from momakitchen.assets import categories_of_kind, get_category
from momakitchen.codec import OMIT_IF_DEFAULT, to_dict
from momakitchen.errors import MomaError
from momakitchen.frames import float3
from momakitchen.robots import get_robot_spec
from momakitchen.robots.spec import (
    DEFAULT_ROBOTS,
    RobotSpec,
    mount_height_problem,
    mount_range_problem,
)
from momakitchen.scene.articulated import (  # noqa: F401  (importable from here too)
    PART_SWEEP,
    articulated_targets,
    handle_anchor,
    part_sweep,
)
from momakitchen.scene.geometry import (
    box_corners,
    corners_of,
    overlap_matrix,
    semicircle_grid,
)
from momakitchen.scene.layout import (
    COUNTER_HEIGHTS,
    Layout,
    Placed,
    _r,
    sample_layout,
    scene_rng,
)

CONFIG_STREAM = 1
MOUNT_STREAM = 4  # seed stream of sampled mount heights (views use 3)

# Stance obstacles stand within this angle (rad) of straight in front of the target: where
# a base facing the target would stop, not off to the side.
STANCE_ARC = np.radians(40.0)
# A part is "hard" (SceneConfig.hard_part_weight) if it is the door of a unit standing on
# the floor, whose panel swings over the floor in front of it (a counter-top appliance's
# door swings over the counter), or if its handle is below LOW_HANDLE (a low drawer, an
# oven's drawer, a freezer) or above HIGH_HANDLE (a high shelf: a fridge's upper door;
# every counter-top appliance's handle is lower), metres.
LOW_HANDLE = 0.45
HIGH_HANDLE = 1.2


@dataclass(frozen=True)
class SceneConfig:
    """How configurations are sampled.

    Attributes:
        configs_per_scene: configurations per scene (paper: ~25 on average).
        objects: (min, max) rigid objects standing on the countertop.
        obstacles: (min, max) obstacles in front of the target.
        rigid_target_prob: probability that the target is a rigid object rather than an
            articulated part.
        grid_spacing: spacing (m) of the trial grid in the semicircle.
        min_free_positions: obstacles are resampled until at least this many positions of
            the sampling grid (or half of those clear of the furniture, if fewer) leave
            the base footprint free: solvable in general, not trivially (obstacles stand
            inside the sampling semicircle, where the robot would like to park).
        min_target_bases: a target is redrawn (up to 8 times) while fewer grid positions
            than this can hold the base clear of furniture and walls.
        robots: robot names assigned round-robin over configurations (``()``: the paper's
            six, ``DEFAULT_ROBOTS``).
        mount_height: every robot's arm mount height in metres, or a range ``(lo, hi)`` to
            draw each configuration's from (:func:`configuration_mount`); None: each robot's
            own (its ``mount_range`` if it has one). Within ``MOUNT_RANGE``. Written to a
            manifest only when set, so datasets made before it existed keep their bytes.
        stance_obstacles: of a configuration's obstacles, up to this many (the first ones)
            stand in the stance band instead of anywhere in the semicircle: their centres
            ``stance_band`` metres from the target's floor point, within ``STANCE_ARC`` of
            straight in front of it, where a base facing the target would naturally stop
            (the distance a reach-based rule picks); one that fits nowhere there (a
            door's sweep may cover the band) stands anywhere. At most ``obstacles[1]``. When
            positive, the ``min_free_positions`` (at least one) that the obstacles leave
            free are counted among the positions from which the target lies within the
            arm's reach of its shoulder (a free position out of reach does not make up
            for a blocked stance), and arrangements that cannot leave them free are
            redrawn with every obstacle anywhere.
        stance_band: ``(lo, hi)`` metres from the target's floor point (see
            ``stance_obstacles``).
        object_depth: rigid objects stand within this distance (m) of the countertop's
            front edge; larger puts some deep on the counter, far from the base.
        hard_part_weight: an articulated target is drawn among the parts in the robot's
            height band with this weight for a hard part (:func:`hard_part`: a door that
            swings over the floor, or a handle below ``LOW_HANDLE`` or above
            ``HIGH_HANDLE``) against 1 for the others.

        The last four are written (to ``scene.json``, to a manifest) only when they differ
        from their defaults, which leave every configuration as it was before they existed.
    """

    configs_per_scene: int = 10
    objects: tuple[int, int] = (1, 3)
    obstacles: tuple[int, int] = (1, 3)
    rigid_target_prob: float = 0.5
    grid_spacing: float = 0.1
    min_free_positions: int = 12
    min_target_bases: int = 20
    robots: tuple[str, ...] = ()
    mount_height: float | tuple[float, float] | None = field(default=None, metadata=OMIT_IF_DEFAULT)
    stance_obstacles: int = field(default=0, metadata=OMIT_IF_DEFAULT)
    stance_band: tuple[float, float] = field(default=(0.5, 0.8), metadata=OMIT_IF_DEFAULT)
    object_depth: float = field(default=0.30, metadata=OMIT_IF_DEFAULT)
    hard_part_weight: float = field(default=1.0, metadata=OMIT_IF_DEFAULT)

    def __post_init__(self) -> None:
        if not 1 <= self.configs_per_scene <= 1000:
            raise MomaError(f"configs_per_scene must be in [1, 1000], got {self.configs_per_scene}")
        for name in ("objects", "obstacles"):
            lo, hi = getattr(self, name)
            if not 0 <= lo <= hi <= 6:
                raise MomaError(f"{name} must satisfy 0 <= min <= max <= 6, got {(lo, hi)}")
        if self.objects[1] < 1:
            raise MomaError(f"objects must allow at least one object, got {self.objects}")
        if not 0.0 <= self.rigid_target_prob <= 1.0:
            raise MomaError(f"rigid_target_prob must be in [0, 1], got {self.rigid_target_prob}")
        if self.min_free_positions < 0 or self.min_target_bases < 0:
            raise MomaError(
                "min_free_positions and min_target_bases must be >= 0, got "
                f"{self.min_free_positions}, {self.min_target_bases}"
            )
        if not 0.02 <= self.grid_spacing <= 0.5:
            raise MomaError(f"grid_spacing must be in [0.02, 0.5] m, got {self.grid_spacing}")
        if not 0 <= self.stance_obstacles <= self.obstacles[1]:
            raise MomaError(
                f"stance_obstacles must be in [0, obstacles max = {self.obstacles[1]}], "
                f"got {self.stance_obstacles}"
            )
        lo, hi = self.stance_band
        if not 0.3 <= lo <= hi <= 2.0:
            raise MomaError(
                f"stance_band must satisfy 0.3 <= min <= max <= 2 m, got {self.stance_band}"
            )
        if not 0.1 <= self.object_depth <= 1.0:
            raise MomaError(f"object_depth must be in [0.1, 1] m, got {self.object_depth}")
        if not 0.0 < self.hard_part_weight <= 100.0:
            raise MomaError(f"hard_part_weight must be in (0, 100], got {self.hard_part_weight}")
        mount = self.mount_height
        if mount is not None:
            problem = (
                mount_range_problem(mount)
                if isinstance(mount, tuple | list)
                else mount_height_problem(mount)
            )
            if problem:
                raise MomaError(f"scene.{problem}")
            if isinstance(mount, list):
                object.__setattr__(self, "mount_height", (float(mount[0]), float(mount[1])))
        for name in self.robot_names:
            usable_robot(name, self)

    @property
    def robot_names(self) -> tuple[str, ...]:
        """The robots assigned round-robin: ``robots``, or ``DEFAULT_ROBOTS``."""
        return self.robots or DEFAULT_ROBOTS

    def mount_heights(self, spec: RobotSpec) -> tuple[float, float]:
        """``(lo, hi)``: the mount heights ``spec``'s configurations may have (one value
        twice for a fixed height)."""
        mount = self.mount_height
        if mount is None:
            return spec.mount_heights
        if isinstance(mount, tuple):
            return (float(mount[0]), float(mount[1]))
        return (float(mount), float(mount))


@dataclass(frozen=True)
class Target:
    """The configuration's target.

    ``uid`` names the placed asset (a rigid object ``r*`` or a furniture unit ``f*``/``a*``);
    for an articulated target ``articulation`` indexes ``model.articulations``.
    ``anchor`` is the world (x, y, z) of the grasp point at rest: the sampling
    semicircle is centred on its floor projection.
    """

    uid: str
    category: str
    articulation: int | None
    anchor: tuple[float, float, float]

    @property
    def is_articulated(self) -> bool:
        return self.articulation is not None


@dataclass(frozen=True)
class Configuration:
    """A scene plus objects, one target, obstacles and the robot used to label it.

    ``mount_height`` is the robot's arm mount height in metres where it was drawn or set by
    the config (:func:`configuration_mount`), None where the robot stands at its own.
    """

    scene_id: int
    index: int
    robot: str
    objects: tuple[Placed, ...]
    target: Target
    obstacles: tuple[Placed, ...]
    mount_height: float | None = None

    @property
    def mount(self) -> float:
        """The arm's mount height in metres: the drawn one or the robot's own."""
        if self.mount_height is not None:
            return self.mount_height
        return get_robot_spec(self.robot).mount_height

    def to_dict(self) -> dict[str, Any]:
        out = {
            "scene_id": self.scene_id,
            "index": self.index,
            "robot": self.robot,
            "target": dataclasses.asdict(self.target),
            "objects": [p.to_dict() for p in self.objects],
            "obstacles": [p.to_dict() for p in self.obstacles],
        }
        if self.mount_height is not None:
            out["mount_height"] = self.mount_height
        return out

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Configuration:
        t = data["target"]
        return cls(
            scene_id=int(data["scene_id"]),
            index=int(data["index"]),
            robot=data["robot"],
            objects=tuple(Placed.from_dict(p) for p in data["objects"]),
            target=Target(t["uid"], t["category"], t["articulation"], tuple(t["anchor"])),
            obstacles=tuple(Placed.from_dict(p) for p in data["obstacles"]),
            mount_height=(
                None if data.get("mount_height") is None else float(data["mount_height"])
            ),
        )


# Shoulders sit about this far above the arm mount (Panda 0.333 m, xArm6 0.267 m, UR5e
# 0.163 m): used only to skip parts that are plainly out of a robot's reach.
SHOULDER_ABOVE_MOUNT = 0.25


def counter_reach_problem(spec: RobotSpec, mounts: tuple[float, float]) -> str | None:
    """Why robot ``spec`` mounted anywhere in ``mounts`` = ``(lo, hi)`` could not reach any
    countertop (:data:`~momakitchen.scene.layout.COUNTER_HEIGHTS`), or None.

    The base stands with its front edge at the counter, the arm ``footprint[0] / 2 -
    mount_offset_x`` behind it; the countertop's front edge must lie within ``reach`` of
    the shoulder (``SHOULDER_ABOVE_MOUNT`` above the mount) at some mount height and some
    counter height. A necessary condition only, cheap enough for every config.
    """
    lo, hi = mounts
    counter_lo, counter_hi = COUNTER_HEIGHTS
    gap = max(
        0.0, counter_lo - (hi + SHOULDER_ABOVE_MOUNT), (lo + SHOULDER_ABOVE_MOUNT) - counter_hi
    )
    standoff = max(0.0, spec.footprint[0] / 2 - spec.mount_offset_x)
    need = float(np.hypot(standoff, gap))
    if need <= spec.reach:
        return None
    heights = f"{lo:g} m" if lo == hi else f"{lo:g}-{hi:g} m"
    source = spec.model.source
    origin = f" ({source})" if source.startswith("user robot") else ""
    return (
        f"robot {spec.name!r}{origin} cannot reach the counter at any mount height: its "
        f"reach is {spec.reach:g} m, but the countertop edge ({counter_lo:g}-{counter_hi:g} m "
        f"high) is at least {need:.2f} m from its shoulder at a mount height of {heights}"
    )


def configuration_mount(
    scene_id: int, index: int, spec: RobotSpec, cfg: SceneConfig
) -> float | None:
    """The arm mount height of configuration ``index`` of scene ``scene_id`` for ``spec``:
    None where neither ``cfg.mount_height`` nor the robot's ``mount_range`` applies (the
    robot stands at its own height), the given height, or one drawn uniformly from the
    range and rounded to the millimetre (its own random stream: deterministic in
    ``(scene_id, index)``, and nothing else drawn for the configuration changes)."""
    chosen = cfg.mount_height if cfg.mount_height is not None else spec.mount_range
    if chosen is None:
        return None
    if not isinstance(chosen, tuple):
        return float(chosen)
    lo, hi = float(chosen[0]), float(chosen[1])
    if lo == hi:
        return lo
    drawn = round(float(scene_rng(scene_id, MOUNT_STREAM, index).uniform(lo, hi)), 3)
    return min(max(drawn, lo), hi)


def usable_robot(name: str, scene_config: SceneConfig) -> RobotSpec:
    """The spec of robot ``name`` for configurations of ``scene_config``; MomaError for an
    unknown robot or one that cannot reach the counter (:func:`counter_reach_problem`)."""
    spec = get_robot_spec(name)
    problem = counter_reach_problem(spec, scene_config.mount_heights(spec))
    if problem:
        raise MomaError(problem)
    return spec


def with_robot(cfg: Configuration, name: str, scene_config: SceneConfig) -> Configuration:
    """The same configuration (objects, target, obstacles) for robot ``name``, with that
    robot's mount height for it (:func:`configuration_mount`); MomaError for an unknown
    robot or one that cannot reach the counter (:func:`usable_robot`)."""
    spec = usable_robot(name, scene_config)
    mount = configuration_mount(cfg.scene_id, cfg.index, spec, scene_config)
    return dataclasses.replace(cfg, robot=name, mount_height=mount)


def within_height_band(z: float, mount_height: float, reach: float) -> bool:
    """Whether a grasp point at height ``z`` is plausibly reachable: from 0.8 x reach below
    to 0.6 x reach above the approximate shoulder height."""
    shoulder = mount_height + SHOULDER_ABOVE_MOUNT
    return shoulder - 0.8 * reach <= z <= shoulder + 0.6 * reach


def hard_part(unit: Placed, articulation: int) -> bool:
    """Whether a functional part makes a hard target (``SceneConfig.hard_part_weight``): the
    door of a unit standing on the floor, which swings over the floor where the base would
    stand, or a handle out of the middle heights (below ``LOW_HANDLE``, above
    ``HIGH_HANDLE``)."""
    z = handle_anchor(unit, articulation)[2]
    door = unit.model.articulations[articulation].part == "door"
    floor_door = door and get_category(unit.category).kind == "furniture"
    return floor_door or not LOW_HANDLE <= z <= HIGH_HANDLE


def _place_objects(
    layout: Layout, rng: np.random.Generator, count: int, depth: float = 0.30
) -> list[Placed]:
    """Stand ``count`` rigid objects on the free countertop, within ``depth`` (m) of its
    front edge."""
    areas = layout.placement_areas()
    rigid = categories_of_kind("rigid")
    placed: list[Placed] = []
    for i in range(count):
        for _attempt in range(40):
            cat = rigid[int(rng.integers(len(rigid)))]
            params = get_category(cat).sample(rng, None)
            sx, sy, _ = get_category(cat).build(params).size
            radius = 0.5 * float(np.hypot(sx, sy)) + 0.01
            area = areas[int(rng.integers(len(areas)))]
            if area.x1 - area.x0 < 2 * radius or area.y1 - area.y0 < 2 * radius + 0.03:
                continue
            x = rng.uniform(area.x0 + radius, area.x1 - radius)
            # Objects stand towards the front edge, where people put things down.
            y_lo = max(area.y0 + radius, area.y1 - depth)
            y = rng.uniform(y_lo, max(y_lo, area.y1 - radius - 0.03))
            if any(
                np.hypot(x - q.x, y - q.y) < radius + 0.5 * np.hypot(*q.model.size[:2]) + 0.02
                for q in placed
            ):
                continue
            yaw = rng.uniform(-np.pi, np.pi)
            placed.append(Placed(f"r{i}", cat, params, _r(x), _r(y), _r(area.z + 0.001), _r(yaw)))
            break
    return placed


def _candidate_bases(
    center: np.ndarray,
    reach: float,
    furniture: np.ndarray,
    footprint: tuple[float, float],
    spacing: float,
    room: Any,
) -> np.ndarray:
    """Corners (N, 4, 2) of base footprints (facing the target) on the sampling grid
    that fit in the room and clear the furniture."""
    grid = semicircle_grid((center[0], center[1]), reach, spacing)
    fps, fits = _facing_bases(grid, center, footprint, furniture, room)
    return fps[fits]


def _facing_bases(
    points: np.ndarray,
    anchor: Any,
    footprint: tuple[float, float],
    blocked: np.ndarray,
    room: Any,
) -> tuple[np.ndarray, np.ndarray]:
    """Base footprints centred on ``points`` (M, 2) and turned to face ``anchor``: their
    corners (M, 4, 2), and (M,) whether each lies in the room clear of ``blocked``
    (K, 4, 2)."""
    yaws = np.arctan2(anchor[1] - points[:, 1], anchor[0] - points[:, 0])
    fps = box_corners(points[:, 0], points[:, 1], yaws, *footprint)
    return fps, _inside_room(fps, room, 0.0) & ~overlap_matrix(fps, blocked).any(1)


def base_fits(
    layout: Layout,
    cfg: Configuration,
    points: np.ndarray,
    footprint: tuple[float, float],
    *,
    include_obstacles: bool = True,
) -> np.ndarray:
    """Where a base of ``footprint`` fits, facing the target, by the floor plan alone.

    The base's box, centred on each point and turned to face the target as in the trials,
    must lie inside the room and clear of the floor-standing furniture's and the
    obstacles' footprints (bounding boxes: conservative, no physics query).
    ``include_obstacles=False``: the room and its furniture only, as a prior map knows
    them (the configuration's obstacles left out).

    Shapes: ``points`` (M, 2) world xy; returns (M,) bool.
    """
    pts = np.asarray(points, np.float64).reshape(-1, 2)
    obstacles = [o.footprint() for o in cfg.obstacles] if include_obstacles else []
    blocked = corners_of(layout.footprints() + obstacles)
    return _facing_bases(pts, cfg.target.anchor, footprint, blocked, layout.room)[1]


ARM_CORRIDOR = 0.12  # m: width of the floor strip the arm sweeps from the base to the target


def _corridors(bases: np.ndarray, anchor: np.ndarray) -> np.ndarray:
    """Corners (N, 4, 2) of the floor strips from each base footprint's centre to the
    target: an obstacle standing on one would be in the arm's way."""
    centres = bases.mean(axis=1)
    d = anchor[:2] - centres
    length = np.hypot(d[:, 0], d[:, 1])
    mid = centres + d / 2
    return box_corners(mid[:, 0], mid[:, 1], np.arctan2(d[:, 1], d[:, 0]), length, ARM_CORRIDOR)


def _inside_room(corners: np.ndarray, room: Any, margin: float) -> np.ndarray:
    """(N,) bool: rectangles (N, 4, 2) at least ``margin`` inside the walls."""
    return (
        (corners.min(axis=(1, 2)) >= margin)
        & (corners[..., 0].max(1) <= room.width - margin)
        & (corners[..., 1].max(1) <= room.depth - margin)
    )


def _place_obstacles(
    layout: Layout,
    rng: np.random.Generator,
    cfg: SceneConfig,
    anchor: np.ndarray,
    reach: float,
    footprint: tuple[float, float],
    keep_clear: np.ndarray | None = None,
    arm: tuple[float, float] | None = None,
) -> tuple[Placed, ...]:
    """1-3 obstacles in the semicircle that leave enough base positions free.

    The first ``cfg.stance_obstacles`` of them stand in the stance band (``cfg.stance_band``
    from the target, within ``STANCE_ARC`` of straight ahead) where one fits, the others
    anywhere; then the positions that count are those within reach (``arm``: the arm's
    axis ahead of the base's centre and the shoulder's height, m), and the second half of
    the arrangements draw every obstacle anywhere.

    A base position stays free if no obstacle overlaps its footprint nor the floor strip
    from it to the target (where the arm reaches over). Each obstacle takes, among random
    poses that fit, the first that keeps ``needed`` base positions free (or the one that
    blocks the fewest); whole arrangements are redrawn up to 10 times. No obstacle
    overlaps ``keep_clear`` (K, 4, 2) either: the floor an articulated target sweeps as it
    opens.
    """
    furniture = corners_of(layout.footprints(margin=0.02))
    if keep_clear is not None:  # e.g. the floor a door sweeps: no obstacle may stand there
        furniture = np.concatenate([furniture, keep_clear])
    bases = _candidate_bases(
        anchor, reach, corners_of(layout.footprints()), footprint, cfg.grid_spacing, layout.room
    )
    stance = cfg.stance_obstacles
    if stance and arm is not None:
        # Obstacles in the stance block the positions within reach: the free ones that
        # count are those, not the far rim of the semicircle.
        ahead, shoulder = arm
        d = np.hypot(*(bases.mean(axis=1) - anchor[:2]).T)
        bases = bases[np.hypot(d - ahead, anchor[2] - shoulder) <= reach]
    corridors = _corridors(bases, anchor)
    kinds = categories_of_kind("obstacle")
    # Where few positions exist at all (a tight corner), keep a good part of them.
    needed = min(cfg.min_free_positions, int(0.5 * len(bases)))
    if stance:
        needed = min(cfg.min_free_positions, max(1, needed), len(bases))
    best: tuple[int, tuple[Placed, ...]] = (-1, ())
    for _attempt in range(10):
        count = int(rng.integers(cfg.obstacles[0], cfg.obstacles[1] + 1))
        placed: list[Placed] = []
        blocked = furniture
        free_bases, free_corridors = bases, corridors
        for i in range(count):
            for _instance in range(4):  # a new instance if this one fits nowhere
                cat = kinds[int(rng.integers(len(kinds)))]
                params = get_category(cat).sample(rng, None)
                sx, sy, _ = get_category(cat).build(params).size
                n = 48
                # Where a base would naturally stop; anywhere once two instances fit
                # nowhere there (a door's sweep may cover the band).
                if i < stance and _instance < 2 and _attempt < 5:
                    r = rng.uniform(cfg.stance_band[0], cfg.stance_band[1], n)
                    theta = rng.uniform(np.pi / 2 - STANCE_ARC, np.pi / 2 + STANCE_ARC, n)
                else:
                    r = rng.uniform(0.5, reach, n)
                    theta = rng.uniform(0.15, np.pi - 0.15, n)
                yaw = np.round(rng.uniform(-np.pi, np.pi, n), 4)
                x = np.round(anchor[0] + r * np.cos(theta), 4)
                y = np.round(anchor[1] + r * np.sin(theta), 4)
                c = box_corners(x, y, yaw, sx, sy)
                ok = _inside_room(c, layout.room, 0.02) & ~overlap_matrix(c, blocked).any(1)
                if ok.any():
                    # (bases still free, candidates): the base or the arm's way blocked
                    hits = overlap_matrix(free_bases, c) | overlap_matrix(free_corridors, c)
                    left = np.where(ok, len(free_bases) - hits.sum(0), -1)
                    good = ok & (left >= needed)
                    k = int(np.argmax(good)) if good.any() else int(np.argmax(left))
                    ob = Placed(
                        f"o{i}", cat, params, float(x[k]), float(y[k]), 0.001, float(yaw[k])
                    )
                    placed.append(ob)
                    blocked = np.concatenate([blocked, ob.footprint(0.02).corners()[None]])
                    free_bases = free_bases[~hits[:, k]]
                    free_corridors = free_corridors[~hits[:, k]]
                    break
        obstacles = corners_of([q.footprint() for q in placed])
        blocked_bases = overlap_matrix(bases, obstacles) | overlap_matrix(corridors, obstacles)
        free = int((~blocked_bases.any(1)).sum())
        if len(placed) >= cfg.obstacles[0]:
            if free >= needed:
                return tuple(placed)
            if free > best[0]:  # otherwise keep the arrangement that blocks the least
                best = (free, tuple(placed))
    return best[1]


def sample_configuration(
    layout: Layout, index: int, cfg: SceneConfig | None = None
) -> Configuration:
    """Configuration ``index`` of ``layout`` (deterministic in ``(scene_id, index, cfg)``)."""
    cfg = cfg or SceneConfig()
    if not 0 <= index < cfg.configs_per_scene:
        raise MomaError(
            f"configuration index must be in [0, {cfg.configs_per_scene - 1}], got {index}"
        )
    rng = scene_rng(layout.scene_id, CONFIG_STREAM, index)
    names = cfg.robot_names
    robot = get_robot_spec(names[(layout.scene_id * 7 + index) % len(names)])
    mount = configuration_mount(layout.scene_id, index, robot, cfg)
    mounted_at = robot.mount_height if mount is None else mount
    objects = _place_objects(
        layout, rng, int(rng.integers(cfg.objects[0], cfg.objects[1] + 1)), cfg.object_depth
    )
    parts = [
        (uid, art)
        for uid, art in articulated_targets(layout)
        if within_height_band(handle_anchor(layout.unit(uid), art)[2], mounted_at, robot.reach)
    ]
    part_p = None
    if cfg.hard_part_weight != 1.0 and parts:
        weights = np.array(
            [cfg.hard_part_weight if hard_part(layout.unit(u), a) else 1.0 for u, a in parts]
        )
        part_p = weights / weights.sum()
    furniture = corners_of(layout.footprints())
    best: tuple[int, Target] | None = None
    for _attempt in range(8):
        if objects and (not parts or rng.random() < cfg.rigid_target_prob):
            obj = objects[int(rng.integers(len(objects)))]
            grasp = obj.model.grasps[0]
            anchor = float3(_r(v) for v in obj.to_world(np.asarray(grasp.position)))
            target = Target(obj.uid, obj.category, None, anchor)
        else:
            pick = rng.integers(len(parts)) if part_p is None else rng.choice(len(parts), p=part_p)
            uid, art = parts[int(pick)]
            target = Target(
                uid, layout.unit(uid).category, art, handle_anchor(layout.unit(uid), art)
            )
        # Targets in a corner leave the base almost nowhere to stand: prefer others.
        room_for_base = len(
            _candidate_bases(
                np.asarray(target.anchor),
                robot.reach,
                furniture,
                robot.footprint,
                cfg.grid_spacing,
                layout.room,
            )
        )
        if best is None or room_for_base > best[0]:
            best = (room_for_base, target)
        if room_for_base >= cfg.min_target_bases:
            break
    assert best is not None  # the loop runs at least once
    target = best[1]
    sweep = (
        part_sweep(layout.unit(target.uid), target.articulation)
        if target.articulation is not None
        else None
    )
    obstacles = _place_obstacles(
        layout,
        rng,
        cfg,
        np.asarray(target.anchor),
        robot.reach,
        robot.footprint,
        sweep,
        (robot.mount_offset_x, mounted_at + SHOULDER_ABOVE_MOUNT),
    )
    return Configuration(
        layout.scene_id, index, robot.name, tuple(objects), target, obstacles, mount
    )


@dataclass(frozen=True)
class Scene:
    """A layout with its configurations."""

    layout: Layout
    configurations: tuple[Configuration, ...]
    config: SceneConfig

    def to_dict(self) -> dict[str, Any]:
        return {
            "schema_version": 1,
            "scene_config": to_dict(self.config),
            "layout": self.layout.to_dict(),
            "configurations": [c.to_dict() for c in self.configurations],
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Scene:
        raw = data["scene_config"]
        values: dict[str, Any] = {k: tuple(v) if isinstance(v, list) else v for k, v in raw.items()}
        config = SceneConfig(**values)
        return cls(
            Layout.from_dict(data["layout"]),
            tuple(Configuration.from_dict(c) for c in data["configurations"]),
            config,
        )


def sample_scene(scene_id: int, cfg: SceneConfig | None = None) -> Scene:
    """The kitchen ``scene_id`` with all its configurations."""
    cfg = cfg or SceneConfig()
    layout = sample_layout(scene_id)
    configs = tuple(sample_configuration(layout, k, cfg) for k in range(cfg.configs_per_scene))
    return Scene(layout, configs, cfg)
