"""One approach: a robot looks, fuses, drives, stops and tries, from one start."""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from momakitchen.deploy.fusion import FusedGoal, LookPolicy, MapFusion
from momakitchen.errors import MomaError
from momakitchen.eval.approach.config import ApproachConfig, perception_corruption
from momakitchen.eval.approach.records import EpisodeRecord, EpisodeSeconds, LookRecord, _round
from momakitchen.sim.motion import (
    BaseState,
    FreeSpace,
    Vec,
    drive,
    face,
    stop_and_face,
)

if TYPE_CHECKING:
    from momakitchen.data.config import GenerationConfig
    from momakitchen.data.episode import ConfigurationLabels
    from momakitchen.robots.spec import RobotSpec
    from momakitchen.scene.configuration import Configuration, Scene
    from momakitchen.sim.trials import TrialRunner
    from momakitchen.sim.world import World

Pose = tuple[float, float, float]
# A baseline's goal in the odometry frame from the base's state and its costmap (None:
# it has none).
GoalOf = Callable[[BaseState, FreeSpace], Pose | None]


# ------------------------------------------------------------------------- perceivers
@dataclass
class LookResult:
    """One look: the prediction (None on failure, with its ``cause``), timings."""

    prediction: Any
    cause: str = ""
    seconds: float = 0.0
    # (M, 2) base-frame xy of the frame's points above the floor (the costmap's obstacle
    # layer reads them); None where the robot knows the whole room.
    obstacles: np.ndarray | None = None


class ModelPerceiver:
    """A trained run (or plug-in) through :func:`momakitchen.predict`, in this process."""

    def __init__(self, run: Any, name: str) -> None:
        self.run, self.name = run, name
        self.preprocessing = run.preprocessing

    def __call__(
        self,
        frame: Any,
        robot: str | tuple[str, float],
        metric: bool,
        config: ApproachConfig,
        opens: bool = False,
    ) -> Any:
        from momakitchen.deploy.predict import predict

        return predict(
            frame.depth,
            frame.intrinsics,
            frame.camera_to_base,
            frame.target_mask,
            robot,
            rgb=frame.rgb,
            obstacle_masks=list(frame.obstacle_masks),
            checkpoint=self.run,
            top_k=1,
            pick_radius=config.pick_radius,
            mc_samples=config.mc_samples,
            metric_depth=metric,
            opens=opens,
        )


class ClassicalPerceiver:
    """A classical base-placement method (:func:`momakitchen.placement.place`) as a look:
    the same frame a model gets, the robot by name and mount height; its map's positive
    cells only. Its map has no spread, so under ``uncertain`` it looks again as ``relook``
    does."""

    has_spread = False

    def __init__(self, name: str) -> None:
        self.name = name

    def __call__(
        self,
        frame: Any,
        robot: str | tuple[str, float],
        metric: bool,
        config: ApproachConfig,
        opens: bool = False,
    ) -> Any:
        from momakitchen.placement.methods import place_frame

        name, mount = (robot, None) if isinstance(robot, str) else robot
        pred = place_frame(
            self.name,
            frame,
            name,
            mount_height=mount,
            metric_depth=metric,
            pick_radius=config.pick_radius,
        )
        # A classical map's zero says "not a stance": only its positive cells are fused,
        # so a look that finds none gives no goal rather than an arbitrary zero cell.
        keep = np.asarray(pred.affordance) > 0
        return replace(
            pred,
            floor_xyz=pred.floor_xyz[keep],
            affordance=pred.affordance[keep],
            uncertainty=pred.uncertainty[keep],
        )


# ------------------------------------------------------------------------ the episode
@dataclass
class Context:
    """What every episode of one configuration shares (the world stays loaded)."""

    scene: Scene
    cfg: Configuration
    labels: ConfigurationLabels
    gen: GenerationConfig
    world: World
    runner: TrialRunner
    free: FreeSpace  # the room's true free space: starts, L*, figures
    known: FreeSpace  # what the robot knows at the start (config.map): it plans on a copy
    spec: RobotSpec
    config: ApproachConfig
    successes: np.ndarray  # (S, 2) world xy of successful grid trials
    feasible: bool

    @property
    def anchor(self) -> np.ndarray:
        return np.asarray(self.cfg.target.anchor, float)

    @property
    def camera_height(self) -> float:
        """The head camera's height: above the configuration's mount (drawn or the
        robot's own), as the dataset's views."""
        return float(self.cfg.mount + self.gen.camera.above_mount)

    @property
    def robot_by_name(self) -> str | tuple[str, float]:
        """The robot as a classical method takes it: its name, or ``(name, mount
        height)`` for a drawn mount height."""
        if self.cfg.mount_height is None:
            return str(self.cfg.robot)
        return (str(self.cfg.robot), float(self.cfg.mount_height))

    def head(self, odom: Vec, target_xyz: Vec) -> np.ndarray:
        """The head camera's transform to the base (4, 4), turned toward ``target_xyz``
        (odometry frame) from the base at ``odom``, as the dataset's views look."""
        from momakitchen.frames import base_to_world
        from momakitchen.perception.camera import look_toward

        eye = np.array([odom[0], odom[1], self.camera_height])
        cam = look_toward(
            eye,
            np.asarray(target_xyz, float),
            self.gen.camera.intrinsics,
            self.gen.views.target_row,
        )
        x, y, yaw = (float(v) for v in odom)
        return np.linalg.inv(base_to_world((x, y, yaw))) @ cam

    def render(self, true: Vec, camera_to_base: np.ndarray) -> Any:
        """The perfect frame of the head at ``camera_to_base`` on the base at ``true``."""
        from momakitchen.data.episode import stored_frame
        from momakitchen.frames import base_to_world
        from momakitchen.generation.producer import semantic_map
        from momakitchen.generation.render import render
        from momakitchen.sim.trials import PARKING

        # Another episode's trial may have moved the target or opened its door: each
        # episode looks at the configuration as it was labelled.
        self.runner.reset()
        # The trial robot is a collision probe that stays where the last check put it;
        # out of the room it does not block the camera (the dataset's views never show it).
        self.runner.robot.place_base(*PARKING)
        cam = self.gen.camera
        r = render(
            self.world.client,
            base_to_world((float(true[0]), float(true[1]), float(true[2]))) @ camera_to_base,
            cam.intrinsics,
            cam.near,
            cam.far,
        )
        arrays = {"depth": r.depth, "rgb": r.rgb, "camera_to_base": camera_to_base}
        arrays["semantic"] = semantic_map(self.world, r.body, r.link)
        arrays["intrinsics"] = cam.intrinsics.as_array()
        # The masks from the segmentation, as a stored episode's frame gets them.
        return stored_frame(arrays)

    def base_free(self, pose: Sequence[float]) -> bool:
        return self.runner.base_free(float(pose[0]), float(pose[1]), float(pose[2]))


def take_look(ctx: Context, perceiver: Any, frame: Any, ids: tuple[int, ...]) -> LookResult:
    """Corrupt a perfect frame by the perception preset and predict on it; a frame the
    method cannot use is a failed look with the error's ``cause``, a fatal error stops.
    With a static map the corrupted frame's points above the floor are the look's
    ``obstacles``; ``perceiver`` None: a look for the costmap only (cause ``costmap``)."""
    from momakitchen.perception.sensors import (
        corrupt_frame,
        corruption_rng,
        get_corruption,
        target_range,
    )

    name = perception_corruption(ctx.config.perception)
    corruption = get_corruption(name)
    t0 = time.perf_counter()
    obstacles = None
    if ctx.config.map == "static":
        bad = corrupt_frame(frame, corruption, corruption_rng(ctx.config.seed, ids, name))
        obstacles = _obstacle_points(bad, corruption.preset.max_range)
    if perceiver is None:
        return LookResult(None, "costmap", 0.0, obstacles)
    distance = target_range(frame)
    if distance > corruption.preset.max_range:
        return LookResult(None, "beyond_range", 0.0, obstacles)
    if not frame.target_mask.any():
        return LookResult(None, "target_not_in_view", 0.0, obstacles)
    if obstacles is None:
        bad = corrupt_frame(frame, corruption, corruption_rng(ctx.config.seed, ids, name))
    # Every method gets the robot by name, at the configuration's drawn mount height if it
    # has one: a model reads its descriptor there, a model's gates and a classical method
    # (here or behind a server) its URDF.
    robot = ctx.robot_by_name
    try:
        pred = perceiver(
            bad, robot, corruption.preset.depth.metric, ctx.config, ctx.cfg.target.is_articulated
        )
    except MomaError as exc:
        if exc.fatal:
            raise
        return LookResult(None, exc.cause, time.perf_counter() - t0, obstacles)
    return LookResult(pred, "", time.perf_counter() - t0, obstacles)


# Every method looks once this far (m, along its path) from its goal when the map is static.
NEAR_GOAL = 1.5
# Observed points within this margin (m) of the prior map's furniture are that furniture.
KNOWN_MARGIN = 0.05
# Obstacle points come from depth within this range (m): beyond it a 1 deg calibration
# error alone lifts the floor by more than OBSTACLE_MIN_HEIGHT.
OBSTACLE_RANGE = 3.0
OBSTACLE_MIN_HEIGHT = 0.10  # m above the floor: its depth noise and calibration stay below


def _obstacle_points(frame: Any, max_range: float) -> np.ndarray:
    """(M, 2) base-frame xy of a (corrupted) frame's points above the floor, the target's
    pixels left out (what the base approaches is no obstacle to it)."""
    from momakitchen.perception.obstacles import obstacle_points

    return obstacle_points(
        frame.depth,
        frame.intrinsics,
        frame.camera_to_base,
        min_height=OBSTACLE_MIN_HEIGHT,
        max_range=min(OBSTACLE_RANGE, max_range),
        exclude_mask=frame.target_mask,
    )


class Episode:
    """One approach from ``start`` (world = odometry frame at the start) by a model
    method (``perceiver``, under ``policy``) or a baseline (``goal_of``).

    :meth:`run` drives it and returns its :class:`EpisodeRecord`; ``first_look`` is the
    first look of the same method and start under another policy (the same pose, frame
    and errors), reused rather than taken again, and :attr:`first` is this episode's.
    ``capture`` adds what a figure or a recording shows (``record.capture``).
    """

    def __init__(
        self,
        ctx: Context,
        start: Pose,
        start_head: np.ndarray,
        start_index: int,
        method: str,
        policy: str,
        goal_of: GoalOf | None = None,
        perceiver: Any = None,
        first_look: LookResult | None = None,
        capture: bool = False,
    ) -> None:
        if (perceiver is None) == (goal_of is None):
            raise MomaError(f"method {method!r}: give either a perceiver or a baseline's goal")
        config = ctx.config
        sid, ci = ctx.cfg.scene_id, ctx.cfg.index
        self.ctx, self.start_head, self.start_index = ctx, start_head, start_index
        self.perceiver, self.goal_of = perceiver, goal_of
        self.first_look, self.capture = first_look, capture
        self.rng = np.random.default_rng([config.seed, sid, ci, start_index, 11])
        self.stop_noise = np.random.default_rng([config.seed, sid, ci, start_index, 12])
        self.state = BaseState(true=start, odom=start, odom_trace=[start])
        self.record = EpisodeRecord(method, policy, path=[_round(start[:2], 3)])
        # A map without spread cannot say how sure it is: ``uncertain`` looks as ``relook``.
        kind = "relook" if policy == "uncertain" and not _has_spread(perceiver) else policy
        self.policy: LookPolicy | None = (
            replace(config.look, kind=kind) if perceiver is not None else None
        )
        self.fusion = MapFusion(cell=config.motion.cell)
        # Where the robot believes the target is (odometry frame): the scene's anchor
        # until a look places it.
        self.target = ctx.anchor.copy()
        self.first: LookResult | None = None
        self.inference = 0.0
        self.heads: list[list[float]] = []
        self.images: list[dict[str, Any] | None] = []  # with capture: each look's frame
        # The robot's costmap: the prior map, and with a static one the obstacles its
        # looks see (its own copy: episodes do not share what they saw).
        self.static = config.map == "static"
        self.costmap = ctx.known.copy() if self.static else ctx.known
        self.looked_near_goal = False

    # ----------------------------------------------------------------------- looking
    def can_look(self) -> bool:
        return self.policy is not None and self.policy.can_look(len(self.record.looks))

    def look(self, head: np.ndarray) -> None:
        """Look with the head at ``head`` (camera to base, 4 x 4) and fuse the map."""
        ctx, state, k = self.ctx, self.state, len(self.record.looks)
        self.heads.append(np.round(head, 5).ravel().tolist())
        if k == 0 and self.first_look is not None:
            result = self.first_look
            self.keep_images(None)
        else:
            frame = ctx.render(state.true, head)
            self.keep_images(frame)
            ids = (ctx.cfg.scene_id, ctx.cfg.index, self.start_index, k)
            result = take_look(ctx, self.perceiver, frame, ids)
        if k == 0:
            self.first = result
        self.inference += result.seconds
        ok = result.prediction is not None
        self.record.looks.append(
            LookRecord(
                _round(state.true), _round(state.odom), ok, result.cause, round(result.seconds, 3)
            )
        )
        if ok:
            self.fusion.add(result.prediction, state.odom)
            assert self.fusion.target_xy is not None
            self.target = np.array([*self.fusion.target_xy, ctx.anchor[2]])
        if result.obstacles is not None:
            self.observe(result.obstacles)

    def keep_images(self, frame: Any) -> None:
        """With ``capture``: a look's rendered colour and depth (metres), every
        ``stride``-th pixel so that they are at most 320 pixels wide (None: a first look
        reused from another policy, not rendered again)."""
        if not self.capture:
            return
        if frame is None:
            self.images.append(None)
            return
        s = max(1, math.ceil(frame.depth.shape[1] / 320))
        rgb, depth = frame.rgb[::s, ::s].copy(), frame.depth[::s, ::s].copy()
        self.images.append({"rgb": rgb, "depth": depth, "stride": s})

    def observe(self, points: np.ndarray) -> None:
        """Add a look's obstacle points (base frame at the look) to the costmap, without
        those on the furniture the prior map already holds, thinned to its cells: a cell
        with fewer than ``config.obstacle_min_points`` of them is not marked."""
        from momakitchen.frames import base_to_world_xy
        from momakitchen.scene.geometry import corners_of

        if not len(points):
            return
        xy = base_to_world_xy(points, self.state.odom)
        cell = self.costmap.step
        keys, counts = np.unique(np.floor(xy / cell), axis=0, return_counts=True)
        xy = keys[counts >= self.ctx.config.obstacle_min_points] * cell + cell / 2
        known = corners_of(self.ctx.scene.layout.footprints(KNOWN_MARGIN))
        self.costmap.observe(xy[~_in_boxes(xy, known)])

    def costmap_look(self, head: np.ndarray | None = None) -> None:
        """A look for the costmap only (a method that does not look, or a policy that
        would not look here): the frame's obstacles, no map; ``head`` default: toward
        the believed target."""
        state, k = self.state, len(self.record.looks)
        if head is None:
            head = self.ctx.head(state.odom, self.target)
        self.heads.append(np.round(head, 5).ravel().tolist())
        frame = self.ctx.render(state.true, head)
        self.keep_images(frame)
        ids = (self.ctx.cfg.scene_id, self.ctx.cfg.index, self.start_index, k)
        result = take_look(self.ctx, None, frame, ids)
        self.record.looks.append(
            LookRecord(_round(state.true), _round(state.odom), False, result.cause, 0.0)
        )
        if result.obstacles is not None:
            self.observe(result.obstacles)

    # ---------------------------------------------------------------------- deciding
    def next_goal(self) -> tuple[Pose | None, FusedGoal | None, str]:
        """The goal to drive to now, the fused goal it came from (models), and why
        there is none (``""`` when there is one). A model without a usable map yet
        drives toward the target and looks again, while its policy allows."""
        ctx, state = self.ctx, self.state
        if self.goal_of is not None:
            goal = self.goal_of(state, self.costmap)
            return goal, None, "" if goal is not None else "no_goal"
        while True:
            fused = self.fusion.goal(self.costmap.reachable(state.odom[:2]), ctx.config.pick_radius)
            if fused is not None:
                row = [*_round(fused.pose), round(fused.affordance, 4), round(fused.uncertainty, 4)]
                self.record.goals = [*(self.record.goals or []), row]
                return fused.pose, fused, ""
            point = _approach_point(self.costmap, state, self.target) if self.can_look() else None
            if point is None:
                return None, None, "no_map" if self.fusion.looks == 0 else "no_goal"
            path = self.costmap.plan(state.odom[:2], point[:2])
            if path is None or self.drive(path, 1.5) is None:
                return None, None, "no_map"
            self.look(ctx.head(state.odom, self.target))

    def drive(self, path: np.ndarray, stop_after: float) -> bool | None:
        """Drive along ``path``; True at its end, False when stopped early to look, None
        when the base was blocked (it stopped at its last free pose, as a bumper would)."""
        ctx, state = self.ctx, self.state
        poses, ok = drive(
            state,
            path,
            self.target[:2],
            ctx.config.motion,
            self.rng,
            check=ctx.base_free,
            stop_after=stop_after,
        )
        self.record.path.extend(_round(p[:2], 3) for p in poses[1:])
        if not ok:
            self.record.blocked = True
            return None
        return bool(np.hypot(*(np.asarray(state.odom[:2]) - path[-1])) < 1e-6)

    # ------------------------------------------------------------------------ the run
    def run(self) -> EpisodeRecord:
        """Look, drive (looking again as the policy says), stop, face the target and
        run the labelling's trial where the base really is."""
        ctx, state, record = self.ctx, self.state, self.record
        cpu0 = time.process_time()
        goal: Pose | None = None
        outcome = ""
        if self.perceiver is not None:
            self.look(self.start_head)
        elif self.static:  # a method that does not look still looks for its costmap
            self.costmap_look(self.start_head)
        while True:
            chosen, fused, outcome = self.next_goal()
            if chosen is None:
                # A model that loses its map keeps its last goal in the record.
                goal = None if self.goal_of is not None else goal
                break
            goal = chosen
            path = self.costmap.plan(state.odom[:2], goal[:2])
            if path is None:
                outcome = "unreachable_goal"
                break
            remaining = float(np.sum(np.hypot(*np.diff(path, axis=0).T)))
            stop_after = math.inf
            if fused is not None and self.policy is not None:
                looks = len(record.looks)
                stop_after = self.policy.next_look(
                    looks, self.fusion, state.odom[:2], fused, remaining
                )
            # With a static map every method looks once within NEAR_GOAL of its goal,
            # where the obstacles that decide the stance stand.
            near = remaining - NEAR_GOAL
            costmap_only = self.static and not self.looked_near_goal and 0 < near < stop_after
            if costmap_only:
                stop_after = near
            arrived = self.drive(path, stop_after)
            if arrived is None or arrived:  # blocked (stopped before contact) or at the goal
                break
            if costmap_only:
                self.looked_near_goal = True
                self.costmap_look()
            else:
                self.looked_near_goal |= remaining - stop_after <= NEAR_GOAL
                self.look(ctx.head(state.odom, self.target))
        record.goal = None if goal is None else _round(goal)
        record.target_odom = _round(self.target[:2])
        if self.capture:
            xy, value, _ = self.fusion.fused()
            record.capture = {
                "odom_path": [_round(p, 4) for p in state.odom_trace],
                "heads": self.heads,
                "images": self.images,
                "fused": {"xy": np.round(xy, 3).tolist(), "value": np.round(value, 4).tolist()},
            }
        self.stop(outcome)
        record.driven = round(state.driven, 3)
        motion = ctx.config.motion
        times = {
            "driving": round(state.driven / motion.speed, 2),
            "turning": round(math.degrees(state.turned) / motion.turn_rate, 2),
            "looking": round(len(record.looks) * motion.look_seconds, 2),
            "inference": round(self.inference, 3),
        }
        record.seconds = EpisodeSeconds(**times, total=round(sum(times.values()), 2))
        record.cpu_seconds = round(time.process_time() - cpu0, 2)
        return record

    def stop(self, outcome: str) -> None:
        """Stop with the controller's error, face the target and run the trial (and the
        stop sweep's); ``outcome``: why no trial runs (``""``: it runs)."""
        ctx, state, record = self.ctx, self.state, self.record
        if outcome:
            record.success, record.stage, record.final = 0, outcome, None
            return
        motion, config = ctx.config.motion, ctx.config
        noise = self.stop_noise.standard_normal(3)
        pre_stop = BaseState(state.true, state.odom, state.driven, state.turned)
        final = _final_pose(ctx, pre_stop, self.target, motion.stop_xy, motion.stop_yaw, noise)
        trial = ctx.runner.run(*final)
        record.success, record.stage = int(trial.success), trial.stage.name.lower()
        record.final = _round(final)
        if config.stop_sweep:
            sweep = []
            for cm, deg in config.stop_sweep:
                if (cm / 100.0, deg) == (motion.stop_xy, motion.stop_yaw):
                    sweep.append(int(trial.success))
                    continue
                pose = _final_pose(ctx, pre_stop, self.target, cm / 100.0, deg, noise)
                sweep.append(int(ctx.runner.run(*pose).success))
            record.stop_sweep = sweep
        state.turned += abs(
            math.atan2(math.sin(final[2] - state.true[2]), math.cos(final[2] - state.true[2]))
        )


def _final_pose(
    ctx: Context,
    state: BaseState,
    target: np.ndarray,
    stop_xy: float,
    stop_yaw: float,
    noise: np.ndarray,
) -> Pose:
    """The stop-error pose, facing the believed target; where the error would put the
    base into furniture, the bumper stops it short (half the error, up to four times)."""
    for k in range(5):
        scale = 0.5**k if k < 4 else 0.0
        pose = stop_and_face(state, target[:2], stop_xy * scale, stop_yaw * scale, noise)
        if ctx.base_free(pose) or k == 4:
            return pose
    raise AssertionError("unreachable")


def _has_spread(perceiver: Any) -> bool:
    """Whether a method's maps come with an uncertainty (models and servers do)."""
    return bool(getattr(perceiver, "has_spread", True))


def _in_boxes(xy: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """(M,) bool: points (M, 2) inside any of the convex quadrilaterals ``corners``
    (B, 4, 2), counter-clockwise."""
    inside = np.zeros(len(xy), bool)
    for quad in corners:
        edges = np.roll(quad, -1, axis=0) - quad  # (4, 2)
        rel = xy[:, None, :] - quad[None]  # (M, 4, 2)
        cross = edges[None, :, 0] * rel[..., 1] - edges[None, :, 1] * rel[..., 0]
        inside |= (cross >= 0).all(axis=1)
    return inside


def _approach_point(free: FreeSpace, state: BaseState, target: np.ndarray) -> Pose | None:
    """A reachable free cell of ``free`` (the robot's costmap) about 2.5 m in front of the
    believed target (the middle of the training views' range), nearest that distance;
    where a robot without a usable map goes to look again."""
    reach = free.reachable(state.odom[:2])
    d = np.hypot(*(free.cells - target[:2]).T)
    order = np.argsort(np.abs(d - 2.5) + 10.0 * ~free.free, kind="stable")
    for i in order[:2000]:
        x, y = free.cells[i]
        if free.free[i] and y > target[1] and reach(x, y):
            return (float(x), float(y), face((x, y), target))
    return None
