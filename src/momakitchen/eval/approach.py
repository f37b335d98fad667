"""The approach track: the last mile as a robot drives it (docs/APPROACH.md).

For each configuration of a split and each start (``near``: the view ``msr`` judges for
the same seed; ``far``: the farthest free pose 3.8-6 m from the target, within +-45 deg
of the direction it faces, that sees it), every method drives the base from the start to
a goal and the labelling's trial runs where the base really stopped:

1. **look**: render the robot's RGB-D frame at its *true* pose (the dataset's renderer),
   apply the perception preset (sensor noise, segmenter mask error, calibration error),
   and run the real-robot path :func:`momakitchen.predict` on it (or a server's
   ``/predict``);
2. **fuse**: the looks' maps in the odometry frame (:class:`~momakitchen.deploy.fusion.MapFusion`),
   the goal the best fused cell the base can reach;
3. **drive**: a shortest collision-free path on the room's free space, driven with
   odometry drift and checked in PyBullet at every step (:mod:`momakitchen.sim.motion`);
   the policy may stop on the way and look again (``relook``, ``uncertain``);
4. **stop**: the controller stops with an error and the base turns, by odometry, to face
   the target; the trial runs at the true final pose.

Baselines drive the same way with the same errors: ``oracle`` (the ground truth's best
successful cell, known from the start), ``nearest`` (the free cell nearest the target),
``random`` (a free cell within the arm's reach of it).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from momakitchen.deploy.fusion import POLICIES, LookPolicy, MapFusion
from momakitchen.errors import MomaError
from momakitchen.models.inference import MC_SAMPLES, PICK_RADIUS
from momakitchen.sim.motion import (
    BaseState,
    FreeSpace,
    MotionConfig,
    Vec,
    drive,
    face,
    stop_and_face,
)

STARTS = ("near", "far")
BASELINES = ("oracle", "nearest", "random")
SPLITS = ("test", "train", "all")
# Named perception presets: a realistic robot's (a D435-like stereo camera, a segmenter's
# masks shifted 5 px, the camera 1 cm high and rolled 1 deg) and a perfect one; any
# corruption name of ``momakitchen robustness --list`` works too.
PERCEPTION = {"realistic": "combined-d435", "ideal": "clean"}
# Final-stop errors of the sweep: (cm, deg) standard deviations.
# 0-10 cm (a docking-grade controller), then two coarser stops: where success halves.
STOP_SWEEP = ((0.0, 0.0), (3.0, 2.0), (6.0, 4.0), (10.0, 6.0), (20.0, 10.0), (30.0, 15.0))


def perception_corruption(name: str) -> str:
    """The corruption of a perception preset name (or a corruption name itself)."""
    from momakitchen.perception.sensors import CORRUPTIONS

    if name in PERCEPTION:
        return PERCEPTION[name]
    if name not in CORRUPTIONS:
        raise MomaError(
            f"unknown perception preset {name!r}; presets: {', '.join(PERCEPTION)} or a "
            "corruption of `momakitchen robustness --list`"
        )
    return name


@dataclass(frozen=True)
class ApproachConfig:
    """Settings of an approach run.

    Attributes:
        starts: ``near`` and/or ``far``.
        policies: look policies of the model methods (:data:`POLICIES`).
        perception: a :data:`PERCEPTION` preset or a corruption name.
        seed: seeds the near start (as ``msr --seed``), motion and perception errors and
            the random baseline; the same for every method.
        split, max_configs: which configurations.
        part: ``(k, n)``: only the scenes ``k-1, k-1+n, ...`` of the split's scenes in
            order (part k of n, to run one split in several processes or on several
            machines; ``scripts/approach_report.py`` merges the parts); (1, 1): all.
        far_range: distance range (m) of far starts; ``far_angle``: deg either side of
            the direction the target faces.
        look: the look policy's thresholds (its ``kind`` is set per policy).
        mc_samples: MC-dropout passes per look (the ``uncertain`` policy reads them).
        pick_radius: goals ranked by the fused map averaged over this radius (m).
        stop_sweep: run the final trial again at these stop errors ((cm, deg) pairs) from
            the same pre-stop pose; () for none.
        motion: driving speed, drift and stop error.
    """

    starts: tuple[str, ...] = ("far",)
    policies: tuple[str, ...] = POLICIES
    perception: str = "realistic"
    seed: int = 0
    split: str = "test"
    max_configs: int = 0
    part: tuple[int, int] = (1, 1)
    far_range: tuple[float, float] = (3.8, 6.0)
    far_angle: float = 45.0
    look: LookPolicy = field(default_factory=LookPolicy)
    mc_samples: int = MC_SAMPLES
    pick_radius: float = PICK_RADIUS
    stop_sweep: tuple[tuple[float, float], ...] = ()
    motion: MotionConfig = field(default_factory=MotionConfig)

    def __post_init__(self) -> None:
        for name, values, allowed in (
            ("start", self.starts, STARTS),
            ("policy", self.policies, POLICIES),
        ):
            if not values:
                raise MomaError(f"no {name} given; choose from {', '.join(allowed)}")
            for v in values:
                if v not in allowed:
                    raise MomaError(f"unknown {name} {v!r}; choose from {', '.join(allowed)}")
            if len(set(values)) != len(values):
                raise MomaError(f"{name} named twice: {list(values)}")
        perception_corruption(self.perception)
        if self.seed < 0 or self.max_configs < 0:
            raise MomaError("seed and max_configs must be >= 0")
        k, n = self.part
        if not 1 <= k <= n:
            raise MomaError(f"part must be K/N with 1 <= K <= N, got {k}/{n}")
        if self.split not in SPLITS:
            raise MomaError(f"split must be one of {SPLITS}, got {self.split!r}")
        lo, hi = self.far_range
        if not (math.isfinite(lo) and math.isfinite(hi) and 1.0 <= lo <= hi <= 15.0):
            raise MomaError(f"far_range must be 1 <= lo <= hi <= 15 m, got {self.far_range}")
        if not 0.0 < self.far_angle <= 90.0:
            raise MomaError(f"far_angle must be in (0, 90] deg, got {self.far_angle}")
        if not 0 <= self.mc_samples <= 64:
            raise MomaError(f"mc_samples must be in [0, 64], got {self.mc_samples}")
        if not 0.0 <= self.pick_radius <= 1.0:
            raise MomaError(f"pick_radius must be in [0, 1] m, got {self.pick_radius}")
        for cm, deg in self.stop_sweep:
            if not (0 <= cm <= 50 and 0 <= deg <= 45):
                raise MomaError(
                    f"stop errors must be in [0, 50] cm and [0, 45] deg, got {cm}, {deg}"
                )

    def to_dict(self) -> dict[str, Any]:
        from dataclasses import asdict

        out = asdict(self)
        out["perception_corruption"] = perception_corruption(self.perception)
        return out


# ------------------------------------------------------------------------- perceivers
@dataclass
class LookResult:
    """One look: the prediction (None on failure, with its ``cause``), timings."""

    prediction: Any
    cause: str = ""
    seconds: float = 0.0


class ModelPerceiver:
    """A trained run (or plug-in) through :func:`momakitchen.predict`, in this process."""

    def __init__(self, run: Any, name: str) -> None:
        self.run, self.name = run, name
        self.preprocessing = run.preprocessing

    def __call__(
        self, frame: Any, robot: str | tuple[float, ...], metric: bool, config: ApproachConfig
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
        )


# ------------------------------------------------------------------------ the episode
@dataclass
class Context:
    """What every episode of one configuration shares (the world stays loaded)."""

    scene: Any
    cfg: Any
    labels: Any
    gen: Any
    world: Any
    runner: Any
    free: FreeSpace
    spec: Any
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
    def robot(self) -> str | tuple[float, ...]:
        """The robot as ``predict`` takes it: its name, or for a drawn mount height its
        descriptor with that height."""
        if self.cfg.mount_height is None:
            return str(self.cfg.robot)
        from momakitchen.robots.descriptor import robot_descriptor

        return robot_descriptor(self.spec, self.cfg.mount_height)

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


def take_look(
    ctx: Context,
    perceiver: Any,
    frame: Any,
    ids: tuple[int, ...],
) -> LookResult:
    """Corrupt a perfect frame by the perception preset and predict on it."""
    from momakitchen.eval.robustness import corruption_rng, error_cause, target_range
    from momakitchen.perception.sensors import corrupt_frame, get_corruption

    name = perception_corruption(ctx.config.perception)
    corruption = get_corruption(name)
    t0 = time.perf_counter()
    distance = target_range(frame)
    if distance > corruption.preset.max_range:
        return LookResult(None, "beyond_range")
    if not frame.target_mask.any():
        return LookResult(None, "target_not_in_view")
    bad = corrupt_frame(frame, corruption, corruption_rng(ctx.config.seed, ids, name))
    try:
        pred = perceiver(bad, ctx.robot, corruption.preset.depth.metric, ctx.config)
    except MomaError as exc:
        if getattr(exc, "fatal", False):
            raise
        return LookResult(None, error_cause(str(exc)), time.perf_counter() - t0)
    return LookResult(pred, "", time.perf_counter() - t0)


def _round(values: Vec, n: int = 4) -> list[float]:
    return [round(float(v), n) for v in values]


def run_episode(
    ctx: Context,
    start: tuple[float, float, float],
    start_head: np.ndarray,
    start_index: int,
    method: str,
    policy: str,
    goal_of: Callable[[BaseState], Any] | None = None,
    perceiver: Any = None,
    first_look: LookResult | None = None,
    capture: bool = False,
) -> tuple[dict[str, Any], LookResult | None]:
    """One approach from ``start`` (world = odometry frame at the start) by a model
    method (``perceiver`` and ``policy``) or a baseline (``goal_of``: its goal in the
    odometry frame, or None). Returns the episode's record and its first look (reused
    by the other policies of the same method and start: the same pose, frame and errors).
    ``capture`` adds what a figure or a recording shows: the odometry path, each look's
    head transform and the fused map (``record["capture"]``).
    """
    config, motion = ctx.config, ctx.config.motion
    sid, ci = ctx.cfg.scene_id, ctx.cfg.index
    cpu0 = time.process_time()
    rng = np.random.default_rng([config.seed, sid, ci, start_index, 11])
    stop_noise = np.random.default_rng([config.seed, sid, ci, start_index, 12]).standard_normal(3)
    state = BaseState(true=start, odom=start, odom_trace=[start])
    record: dict[str, Any] = {
        "method": method,
        "policy": policy,
        "looks": [],
        "blocked": False,
        "path": [_round(start[:2], 3)],
    }
    inference = 0.0
    target = ctx.anchor.copy()  # where the robot believes the target is (odometry frame)
    look_policy = replace(config.look, kind=policy) if perceiver is not None else None
    fusion = MapFusion(cell=motion.cell)
    first: LookResult | None = None

    heads: list[list[float]] = []

    def look(head: np.ndarray) -> None:
        nonlocal inference, first, target
        k = len(record["looks"])
        heads.append(np.round(head, 5).ravel().tolist())
        if k == 0 and first_look is not None:
            result = first_look
        else:
            frame = ctx.render(state.true, head)
            result = take_look(ctx, perceiver, frame, (sid, ci, start_index, k))
        if k == 0:
            first = result
        inference += result.seconds
        record["looks"].append(
            {
                "true": _round(state.true),
                "odom": _round(state.odom),
                "ok": result.prediction is not None,
                "cause": result.cause,
                "seconds": round(result.seconds, 3),
            }
        )
        if result.prediction is not None:
            fusion.add(result.prediction, state.odom)
            assert fusion.target_xy is not None
            target = np.array([*fusion.target_xy, ctx.anchor[2]])

    outcome, goal, fused = "", None, None

    def can_look() -> bool:
        return (
            look_policy is not None
            and look_policy.kind != "single"
            and len(record["looks"]) < look_policy.max_looks
        )

    if perceiver is not None:
        look(start_head)
    while True:
        if perceiver is None:
            assert goal_of is not None
            goal = goal_of(state)
            if goal is None:
                outcome = "no_goal"
                break
        else:
            fused = fusion.goal(ctx.free.reachable(state.odom[:2]), config.pick_radius)
            if fused is None:
                # No usable map yet: come closer to the target and look again.
                point = _approach_point(ctx, state, target) if can_look() else None
                if point is None:
                    outcome = "no_map" if fusion.looks == 0 else "no_goal"
                    break
                path = ctx.free.plan(state.odom[:2], point[:2])
                if path is None or _drive_path(ctx, state, path, target, rng, record, 1.5) is None:
                    outcome = "no_map"
                    break
                look(ctx.head(state.odom, target))
                continue
            goal = fused.pose
            record.setdefault("goals", []).append(
                [*_round(fused.pose), round(fused.affordance, 4), round(fused.uncertainty, 4)]
            )
        path = ctx.free.plan(state.odom[:2], goal[:2])
        if path is None:
            outcome = "unreachable_goal"
            break
        remaining = float(np.sum(np.hypot(*np.diff(path, axis=0).T)))
        stop_after = math.inf
        if fused is not None and can_look():
            assert look_policy is not None
            if look_policy.kind == "relook":
                if len(record["looks"]) < 2 and remaining > look_policy.relook_distance:
                    stop_after = remaining - look_policy.relook_distance
            elif fusion.look_again(look_policy, state.odom[:2], fused) and remaining > 1.0:
                stop_after = max(0.5, 0.5 * remaining)
        arrived = _drive_path(ctx, state, path, target, rng, record, stop_after)
        if arrived is None or arrived:  # blocked (stopped before contact) or at the goal
            break
        look(ctx.head(state.odom, target))

    record["goal"] = None if goal is None else _round(goal)
    record["target_odom"] = _round(target[:2])
    if capture:
        xy, value, _ = fusion.fused()
        record["capture"] = {
            "odom_path": [_round(p, 4) for p in state.odom_trace],
            "heads": heads,
            "fused": {"xy": np.round(xy, 3).tolist(), "value": np.round(value, 4).tolist()},
        }
    pre_stop = BaseState(state.true, state.odom, state.driven, state.turned)
    if outcome:
        record.update(success=0, stage=outcome, final=None)
    else:
        final = _final_pose(ctx, pre_stop, target, motion.stop_xy, motion.stop_yaw, stop_noise)
        trial = ctx.runner.run(*final)
        record.update(
            success=int(trial.success), stage=trial.stage.name.lower(), final=_round(final)
        )
        if config.stop_sweep:
            sweep = []
            for cm, deg in config.stop_sweep:
                if (cm / 100.0, deg) == (motion.stop_xy, motion.stop_yaw):
                    sweep.append(int(trial.success))
                    continue
                pose = _final_pose(ctx, pre_stop, target, cm / 100.0, deg, stop_noise)
                sweep.append(int(ctx.runner.run(*pose).success))
            record["stop_sweep"] = sweep
        state.turned += abs(
            math.atan2(math.sin(final[2] - state.true[2]), math.cos(final[2] - state.true[2]))
        )
    n_looks = len(record["looks"])
    record["driven"] = round(state.driven, 3)
    record["seconds"] = {
        "driving": round(state.driven / motion.speed, 2),
        "turning": round(math.degrees(state.turned) / motion.turn_rate, 2),
        "looking": round(n_looks * motion.look_seconds, 2),
        "inference": round(inference, 3),
    }
    record["seconds"]["total"] = round(sum(record["seconds"].values()), 2)
    record["cpu_seconds"] = round(time.process_time() - cpu0, 2)
    return record, first


def _final_pose(
    ctx: Context,
    state: BaseState,
    target: np.ndarray,
    stop_xy: float,
    stop_yaw: float,
    noise: np.ndarray,
) -> tuple[float, float, float]:
    """The stop-error pose, facing the believed target; where the error would put the
    base into furniture, the bumper stops it short (half the error, up to four times)."""
    for k in range(5):
        scale = 0.5**k if k < 4 else 0.0
        pose = stop_and_face(state, target[:2], stop_xy * scale, stop_yaw * scale, noise)
        if ctx.base_free(pose) or k == 4:
            return pose
    raise AssertionError("unreachable")


def _drive_path(
    ctx: Context,
    state: BaseState,
    path: np.ndarray,
    target: np.ndarray,
    rng: np.random.Generator,
    record: dict[str, Any],
    stop_after: float,
) -> bool | None:
    """Drive along ``path``; True at its end, False when stopped early to look, None when
    the base was blocked (it stopped at its last free pose, as a bumper would)."""
    poses, ok = drive(
        state, path, target[:2], ctx.config.motion, rng, check=ctx.base_free, stop_after=stop_after
    )
    record["path"].extend(_round(p[:2], 3) for p in poses[1:])
    if not ok:
        record["blocked"] = True
        return None
    return bool(np.hypot(*(np.asarray(state.odom[:2]) - path[-1])) < 1e-6)


def _approach_point(
    ctx: Context, state: BaseState, target: np.ndarray
) -> tuple[float, float, float] | None:
    """A reachable free cell about 2.5 m in front of the believed target (the middle of
    the training views' range), nearest that distance; where a robot without a usable
    map goes to look again."""
    reach = ctx.free.reachable(state.odom[:2])
    d = np.hypot(*(ctx.free.cells - target[:2]).T)
    order = np.argsort(np.abs(d - 2.5) + 10.0 * ~ctx.free.free, kind="stable")
    for i in order[:2000]:
        x, y = ctx.free.cells[i]
        if ctx.free.free[i] and y > target[1] and reach(x, y):
            return (float(x), float(y), face((x, y), target))
    return None
