"""Manipulation trials executed in PyBullet physics: one trial per base position.

A trial runs in stages and records the first that failed:

1. the base footprint collides with the scene -> ``BASE_COLLISION``;
2. the grasp point lies outside the arm's workspace sphere (kinematic pre-filter)
   -> ``OUT_OF_REACH``;
3. IK for the pre-grasp and grasp poses (end-effector aligned with the target's surface
   normal or handle) misses -> ``IK_FAILED``;
4. the arm at either pose collides with the scene -> ``ARM_COLLISION``;
5. the manipulation is executed in physics: grasp and lift (grippers), touch, attach and
   lift (suction), or grasp the handle and pull it open (articulated targets). Outcome 1
   only if the object really moved as intended, else ``EXECUTION_FAILED``.

The world is restored to the same saved state before every trial, so trials do not leak
state into each other and any subset of positions gives the same outcomes.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import numpy as np

from momakitchen.assets import GraspFrame
from momakitchen.bullet import p
from momakitchen.errors import MomaError
from momakitchen.robots.robot import Robot
from momakitchen.robots.tools import ParallelGripperTool, SuctionTool
from momakitchen.robots.urdf import BASE_LINK
from momakitchen.sim.config import Stage, TrialConfig
from momakitchen.sim.world import TargetInfo, World

PARKING = (-20.0, -20.0, 0.0)  # where the robot waits between trials, far from the room
# One move of a pull: the hand aims this far beyond the part's measured opening (rad for
# doors and levers, m for drawers), in PULL_WAYPOINTS position-controlled waypoints of
# PULL_STEPS physics steps each.
PULL_STEP = {"revolute": math.radians(4.0), "prismatic": 0.025}
PULL_WAYPOINTS, PULL_STEPS = 2, 10


@dataclass(frozen=True)
class TrialResult:
    """One trial: stage reached, outcome and measurements.

    ``moved`` is the object's rise (m) for rigid targets or the joint opening (rad or m)
    for articulated ones; ``grasp`` names the grasp frame used. ``t_check``, ``t_ik``
    and ``t_physics`` split the trial's wall time (s). ``why`` says what stopped a failed
    trial, for diagnosis only (labels never depend on it): the colliding pairs
    (``"LINK with OTHER"``) of a base or arm collision, or what went wrong in execution.
    """

    stage: Stage
    moved: float = 0.0
    grasp: str = ""
    t_check: float = 0.0
    t_ik: float = 0.0
    t_physics: float = 0.0
    why: tuple[str, ...] = ()
    # diagnosis: the pose IK failed at (explain_ik)
    ik_pose: tuple[np.ndarray, np.ndarray] | None = field(default=None, compare=False, repr=False)

    @property
    def success(self) -> bool:
        return self.stage == Stage.SUCCESS


def tcp_quaternion(normal: np.ndarray, closing: np.ndarray) -> np.ndarray:
    """TCP orientation approaching along ``-normal`` with fingers closing along ``closing``.

    TCP convention (robots module): z = approach direction, y = finger closing axis.
    """
    z = -normal / np.linalg.norm(normal)
    y = closing - (closing @ z) * z
    y /= np.linalg.norm(y)
    x = np.cross(y, z)
    rot = np.stack([x, y, z], axis=1)
    # Rotation matrix to quaternion (x, y, z, w).
    w = math.sqrt(max(0.0, 1.0 + rot[0, 0] + rot[1, 1] + rot[2, 2])) / 2
    if w > 1e-3:
        return np.array(
            [
                (rot[2, 1] - rot[1, 2]) / (4 * w),
                (rot[0, 2] - rot[2, 0]) / (4 * w),
                (rot[1, 0] - rot[0, 1]) / (4 * w),
                w,
            ]
        )
    i = int(np.argmax(np.diag(rot)))
    j, k = (i + 1) % 3, (i + 2) % 3
    s = math.sqrt(max(0.0, 1.0 + rot[i, i] - rot[j, j] - rot[k, k])) * 2
    q = np.zeros(4)
    q[i] = s / 4
    q[j] = (rot[j, i] + rot[i, j]) / s
    q[k] = (rot[k, i] + rot[i, k]) / s
    q[3] = (rot[k, j] - rot[j, k]) / s
    return q


@dataclass(frozen=True)
class _Plan:
    grasp: GraspFrame
    q_pre: np.ndarray
    q_grasp: np.ndarray
    position: np.ndarray  # grasp point (world)
    normal: np.ndarray
    quat: np.ndarray


class TrialRunner:
    """Runs trials of one robot on the loaded configuration of a :class:`World`.

    Loads the robot (parked outside the room), saves the world state, and restores it
    before every trial. The robot's arm stands at ``mount_height`` (metres), by default at
    the loaded configuration's (``Configuration.mount_height``: drawn for it, or the
    robot's own). With ``diagnose``, a position where IK fails keeps the pose it failed at
    (``TrialResult.ik_pose``) for :meth:`explain_ik`.
    """

    def __init__(
        self,
        world: World,
        robot_name: str,
        config: TrialConfig | None = None,
        mount_height: float | None = None,
        diagnose: bool = False,
    ):
        if world.configuration is None:
            raise MomaError("load a configuration into the world before running trials")
        self.world = world
        self.config = config or TrialConfig()
        if mount_height is None and world.configuration.robot == robot_name:
            mount_height = world.configuration.mount_height
        self.robot = Robot(world.client, robot_name, base=PARKING, mount_height=mount_height)
        self.target: TargetInfo = world.target
        c = world.client
        floor = world.bodies["floor"].body_id
        self._scene_bodies = np.array([b for b in world.body_ids() if b != floor])
        # Bounding boxes of the static scene, to query PyBullet only about nearby bodies.
        self._boxes = np.stack([world.aabb(int(b)) for b in self._scene_bodies])
        self._floor = floor
        # Readable names of the scene's bodies and links, e.g. "counter f2" (diagnosis).
        self._body_names = {
            info.body_id: (f"{info.category} {info.uid}", {i: n for n, i in info.links.items()})
            for info in world.bodies.values()
        }
        self._contacts: set[str] = set()  # colliding pairs met while planning one trial
        self._why = ""  # why the last execution failed
        self._diagnose = diagnose
        self._ik_pose: tuple[np.ndarray, np.ndarray] | None = None  # set by an IK failure
        self._allow: list[int | tuple[int, int]] = [self.target.body_id]
        if self.target.is_articulated:
            # The tool may touch the moving part and its handle, not the carcass.
            assert self.target.joint_index is not None
            self._allow = [
                (self.target.body_id, self.target.link_index),
                (self.target.body_id, self.target.joint_index),
            ]
        self.tool = self.robot.tool
        # Free bodies away from the target, and the other furniture (their doors and
        # drawers), rest until something touches them (Bullet's deactivation): they cost
        # no solver time, and contact wakes them as usual.
        grasp_point = world.grasp_in_world()[0]
        self._resting = []
        for info in world.bodies.values():
            if info.body_id == self.target.body_id or info.kind == "structure":
                continue
            if info.kind in ("rigid", "obstacle"):
                lo, hi = world.aabb(info.body_id)
                if (
                    np.linalg.norm(np.maximum(np.maximum(lo - grasp_point, grasp_point - hi), 0))
                    <= 0.25
                ):
                    continue
            self._resting.append(info.body_id)
        for body in self._resting:  # may sleep: else PyBullet wakes them at the next step
            p.changeDynamics(
                body, -1, activationState=p.ACTIVATION_STATE_ENABLE_SLEEPING, physicsClientId=c
            )
        self._solver_before = p.getPhysicsEngineParameters(physicsClientId=c)["numSolverIterations"]
        p.setPhysicsEngineParameter(
            numSolverIterations=self.config.solver_iterations, physicsClientId=c
        )
        self._client = c
        self._state = world.save_state()
        self._restore()

    def _restore(self) -> None:
        """Back to the saved state. Activation (sleeping) is not part of PyBullet's saved
        state, so it is set again: a body woken in one trial must not stay awake."""
        self.world.restore_state(self._state)
        for body in self._resting:
            p.changeDynamics(
                body, -1, activationState=p.ACTIVATION_STATE_SLEEP, physicsClientId=self._client
            )
        self._dirty = False  # True once physics has run since the last restore

    def close(self) -> None:
        """Remove the robot and the saved state from the world."""
        p.removeState(self._state, physicsClientId=self._client)
        p.setPhysicsEngineParameter(
            numSolverIterations=self._solver_before, physicsClientId=self._client
        )
        self.robot.remove()

    # ---------------------------------------------------------------- planning
    def _grasp_candidates(self, base_xy: np.ndarray) -> list[GraspFrame]:
        t = self.target
        if t.is_articulated:
            return [t.grasp]
        info = next(b for b in self.world.bodies.values() if b.body_id == t.body_id)
        _, rot = self.world.link_pose(t.body_id, t.link_index)
        to_robot = np.append(base_xy, 0.0) - self.world.grasp_in_world()[0]
        to_robot[2] = 0.0
        to_robot /= max(np.linalg.norm(to_robot), 1e-9)

        com = np.asarray(
            p.getDynamicsInfo(t.body_id, t.link_index, physicsClientId=self._client)[3]
        )

        def score(g: GraspFrame) -> float:
            n = rot @ np.asarray(g.normal)
            if n[2] <= 0.7:
                return float(n @ to_robot)
            # Top grasps rank about as a side grasp facing the robot at 45 degrees would:
            # those nearest the centre of mass first (the least torque to hold level: a
            # pot's rim before its handles), then those on the robot's side.
            offset = rot @ (np.asarray(g.position) - com)
            offset[2] = 0.0
            d = float(np.linalg.norm(offset))
            return 0.7 - 0.5 * d + (0.02 * float(offset @ to_robot) / d if d > 1e-3 else 0.0)

        assert info.model is not None  # a target always has its asset model
        grasps = list(info.model.grasps)
        if isinstance(self.tool, SuctionTool):
            grasps = [g for g in grasps if g.width >= self.tool.min_surface_width]
        grasps = sorted(grasps, key=score, reverse=True)
        grasps = [g for g in grasps if score(g) > -0.2]
        return grasps[: self.config.max_grasp_candidates]

    def _plan(self, base_xy: np.ndarray, bodies: list[int]) -> tuple[Stage, _Plan | None, float]:
        """IK for pre-grasp and grasp poses over the grasp candidates; (stage, plan, t_ik)."""
        robot, cfg = self.robot, self.config
        t_ik = 0.0
        self._contacts = set()
        self._ik_pose = None
        first: tuple[np.ndarray, np.ndarray] | None = None  # the first pre-grasp tried
        reachable = False
        collided = False
        pos_l, rot_l = self.world.link_pose(self.target.body_id, self.target.link_index)
        for g in self._grasp_candidates(base_xy):
            normal = rot_l @ np.asarray(g.normal)
            pos = rot_l @ np.asarray(g.position) + pos_l
            if isinstance(self.tool, ParallelGripperTool):  # fingers close around the part
                pos = pos - min(g.width / 2, cfg.max_grasp_depth) * normal
            closing = rot_l @ np.asarray(g.closing_axis)
            if not robot.could_reach(pos):
                continue
            reachable = True
            for approach, sign in self._approaches(normal, closing):
                quat = tcp_quaternion(approach, sign * closing)
                if first is None:
                    first = (pos + cfg.pregrasp_offset * approach, quat)
                # Distinct arm configurations for the pre-grasp, until one is free of
                # collisions at both poses (an IK answer alone may fold the arm into the
                # base or sweep it through an obstacle).
                pres = robot.ik_solutions(
                    pos + cfg.pregrasp_offset * approach, quat, starts=1 + cfg.ik_restarts
                )
                while True:
                    t0 = time.perf_counter()  # IK time: the next solution and its grasp
                    pre = next(pres, None)
                    grasp = (
                        None if pre is None else robot.solve_ik(pos, quat, seed=pre.q, restarts=0)
                    )
                    t_ik += time.perf_counter() - t0
                    if pre is None or grasp is None:
                        break
                    if not grasp.success:
                        continue
                    if self._arm_collides(pre.q, bodies) or self._arm_collides(grasp.q, bodies):
                        collided = True
                        continue
                    return Stage.SUCCESS, _Plan(g, pre.q, grasp.q, pos, approach, quat), t_ik
        if not reachable:
            return Stage.OUT_OF_REACH, None, t_ik
        if not collided and self._diagnose:
            self._ik_pose = first
        return (Stage.ARM_COLLISION if collided else Stage.IK_FAILED), None, t_ik

    def explain_ik(self, x: float, y: float, result: TrialResult) -> TrialResult:
        """``result``, an IK failure of :meth:`run` at ``(x, y)`` (with ``diagnose``), with
        ``why``: the arm joints at a limit in the best (failed) solution of its first
        pre-grasp pose, e.g. ``"joint_2 at its limit"``, or that none is; a robot's own
        kinematics (a joint range too short for the pose) reads apart from a poor start.
        Call it after the last trial: its IK moves the arm, which would change later
        trials' physics in the last digits, and diagnosis must not change an outcome."""
        if result.ik_pose is None:
            return result
        robot = self.robot
        self._place(x, y, None)
        res = robot.solve_ik(*result.ik_pose, seed=robot.home)
        if res.success:  # found with more restarts than planning allows
            return replace(result, why=("solved only with more IK restarts",))
        span = 1e-3 * np.maximum(robot.upper - robot.lower, 1.0)
        at = (res.q <= robot.lower + span) | (res.q >= robot.upper - span)
        names = [f"{robot.joint_names[j]} at its limit" for j in np.flatnonzero(at)]
        return replace(result, why=tuple(names) or ("no joint at a limit",))

    def _approaches(
        self, normal: np.ndarray, closing: np.ndarray
    ) -> list[tuple[np.ndarray, float]]:
        """(approach normal, closing sign) pairs to try, in order: along the surface normal
        with either finger first (a two-finger grasp is symmetric about the closing axis),
        then, for grippers, turned by ``TrialConfig.approach_tilt_deg`` about the closing
        axis, where the pads still hold (from above first): a high-mounted arm reaches a
        low handle more easily from above. A suction cup stays flush with the surface."""
        signs = (1.0, -1.0)
        out = [(normal, sign) for sign in signs]
        tilt = math.radians(self.config.approach_tilt_deg)
        if tilt > 0 and isinstance(self.tool, ParallelGripperTool):
            side = np.cross(closing, normal)  # Rodrigues about the closing axis (normal ⟂ it)
            turned = [normal * math.cos(t) + side * math.sin(t) for t in (tilt, -tilt)]
            turned.sort(key=lambda n: -n[2])  # the approach from above first
            out += [(n, sign) for n in turned for sign in signs]
        return out

    def _near(self, x: float, y: float, radius: float) -> list[int]:
        """Scene bodies whose bounding box comes within ``radius`` of (x, y) in the plane."""
        lo, hi = self._boxes[:, 0, :2], self._boxes[:, 1, :2]
        gap = np.maximum(np.maximum(lo - [x, y], [x, y] - hi), 0.0)
        return self._scene_bodies[np.hypot(gap[:, 0], gap[:, 1]) <= radius].tolist()

    def _name(self, body: int, link: int) -> str:
        """A readable name of a body's link: the robot's link names, scene bodies by name."""
        robot = self.robot
        if body == robot.body:
            return BASE_LINK if link < 0 else robot.link_names[link]
        if body not in self._body_names:
            return f"body {body}"
        name, links = self._body_names[body]
        return f"{name} {links[link]}" if link >= 0 and link in links else name

    def _arm_collides(self, q: np.ndarray, bodies: list[int]) -> bool:
        self.robot.set_joint_positions(q)
        contacts = self.robot.arm_collisions(bodies, allow=self._allow)
        for ct in contacts:  # kept for the diagnosis: which links keep colliding
            self._contacts.add(f"{ct.link} with {self._name(ct.body, ct.other_link)}")
        return bool(contacts)

    # ---------------------------------------------------------------- execution
    def _drive(self, q_from: np.ndarray, q_to: np.ndarray, waypoints: int, steps: int) -> None:
        for k in range(1, waypoints + 1):
            self.robot.drive_to(q_from + (q_to - q_from) * k / waypoints, steps, tol=2e-3)

    def _object_height(self) -> float:
        pos = p.getBasePositionAndOrientation(self.target.body_id, physicsClientId=self._client)
        return float(pos[0][2])

    def _execute(self, plan: _Plan) -> tuple[bool, float]:
        """Run the manipulation in physics: take hold of the target with the tool, then
        lift it or pull it open; return (success, amount moved)."""
        robot, world, tool, body = self.robot, self.world, self.tool, self.target.body_id
        if isinstance(tool, ParallelGripperTool):
            tool.set_opening(tool.max_opening)
        robot.set_joint_positions(plan.q_pre)
        world.step(5)
        if isinstance(tool, SuctionTool):
            # Press 5 mm into the surface so that the cup face is in contact.
            res = robot.solve_ik(
                plan.position - 0.005 * plan.normal, plan.quat, seed=plan.q_grasp, restarts=0
            )
            self._drive(plan.q_pre, res.q, 3, 15)
            world.step(5)
            if tool.on([body]) != body:
                self._why = "the suction cup attached nothing"
                return False, 0.0
            q_held = res.q
        else:
            self._drive(plan.q_pre, plan.q_grasp, 3, 15)
            tool.close()
            tool.settle()  # an object between the fingers stops them early
            if not tool.holds(body):
                self._why = "the fingers closed on nothing"
                return False, 0.0  # the fingers closed on nothing (or on something else)
            q_held = robot.joint_positions()
        if self.target.is_articulated:
            return self._pull(q_held)
        return self._lift(plan, q_held)

    def _lift(self, plan: _Plan, q_held: np.ndarray) -> tuple[bool, float]:
        robot, cfg, world = self.robot, self.config, self.world
        z0 = self._object_height()
        tcp_pos, tcp_quat = robot.tcp_pose()
        up = robot.solve_ik(
            tcp_pos + np.array([0, 0, cfg.lift_height]),
            tcp_quat,
            seed=q_held,
            restarts=0,
            pos_tol=0.01,
            ori_tol=math.radians(5),
        )
        if not up.success:
            self._why = "no IK for the lift"
            return False, 0.0
        robot.set_joint_positions(q_held)  # solve_ik leaves the arm at its solution
        self._drive(q_held, up.q, 4, 15)
        # A loaded arm lags its commands: let it arrive before judging the lift.
        robot.drive_to(up.q, 60, tol=2e-3)
        if self._object_height() - z0 < cfg.min_lift:
            self._why = "the object did not rise"
            return False, self._object_height() - z0  # it did not come up: no need to hold
        world.step(round(cfg.hold_seconds * 240))
        rise = self._object_height() - z0
        ok = bool(rise >= cfg.min_lift and self.tool.holds(self.target.body_id))
        if not ok:
            self._why = "the object slipped while held"
        return ok, rise

    def _link_frame(self) -> tuple[np.ndarray, np.ndarray]:
        """The world pose (position, quaternion) of the target part's link frame, which
        sits on its joint (URDF convention)."""
        t = self.target
        pos, quat = p.getLinkState(
            t.body_id, t.link_index, computeForwardKinematics=True, physicsClientId=self._client
        )[4:6]
        return np.asarray(pos), np.asarray(quat)

    def _opened_pose(
        self, tcp_in_link: tuple, axis_local: np.ndarray, amount: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """The TCP pose that holds the handle once the part has opened ``amount`` (rad or
        m) beyond its measured position: the part's link frame turned about (or moved
        along) the joint axis (``axis_local``, in that frame), with the grasp fixed in it."""
        t = self.target
        lp, lq = self._link_frame()
        rot = np.array(p.getMatrixFromQuaternion(lq.tolist())).reshape(3, 3)
        axis = rot @ axis_local
        step = t.open_direction * amount
        if t.joint_type == "revolute":
            turn = p.getQuaternionFromAxisAngle(axis.tolist(), step)
            lq = np.asarray(p.multiplyTransforms((0, 0, 0), turn, (0, 0, 0), lq.tolist())[1])
        else:
            lp = lp + step * axis
        pos, quat = p.multiplyTransforms(lp.tolist(), lq.tolist(), *tcp_in_link)
        return np.asarray(pos), np.asarray(quat)

    def _follow(
        self,
        tcp_in_link: tuple,
        axis_local: np.ndarray,
        held_quat: np.ndarray,
        q: np.ndarray,
        amounts: tuple[float, ...],
    ) -> np.ndarray | None:
        """Arm configuration (dof,) that holds the handle once the part opens by the first
        of ``amounts`` the arm can follow from ``q``; None if it can follow none. The
        physical arm state is left as it was (IK moves the arm kinematically)."""
        tilt = math.radians(self.config.approach_tilt_deg)
        # Turns of the hand about its closing axis (TCP y), where the pads still hold.
        turns = [(0.0, 0.0, 0.0, 1.0)] + [
            p.getQuaternionFromAxisAngle((0.0, 1.0, 0.0), t) for t in (tilt, -tilt) if t
        ]
        with self.robot.kinematic_scratch():
            for amount in amounts:
                pos, quat = self._opened_pose(tcp_in_link, axis_local, amount)
                # The fingers may turn about the handle bar: besides following the
                # handle's frame, accept keeping the grasp orientation or halfway, and
                # the hand turned about its closing axis.
                for turn in turns:
                    for frac in (1.0, 0.0, 0.5):
                        goal = p.getQuaternionSlerp(held_quat.tolist(), quat.tolist(), frac)
                        goal = p.multiplyTransforms((0, 0, 0), goal, (0, 0, 0), turn)[1]
                        res = self.robot.solve_ik(
                            pos, goal, seed=q, restarts=0, pos_tol=0.01, ori_tol=math.radians(6)
                        )
                        if res.success:
                            return res.q
        return None

    def _pull(self, q_held: np.ndarray) -> tuple[bool, float]:
        """Open the part in closed loop: each move aims the hand at where the handle will
        be a small step beyond the part's *measured* opening, so the hand never runs
        ahead of a part that lags (the grasp would tear off). Where the arm cannot follow
        a step (the workspace ends), a half step is tried before stopping."""
        robot, cfg, world, t = self.robot, self.config, self.world, self.target
        q_start = world.joint_position(t)
        revolute = t.joint_type == "revolute"
        goal = math.radians(cfg.pull_angle_deg) if revolute else cfg.pull_distance
        goal = min(goal, t.limit) if t.limit > 0 else goal
        need = math.radians(cfg.open_angle_deg) if revolute else cfg.open_distance
        step = PULL_STEP["revolute" if revolute else "prismatic"]
        # The grasp as it really is after closing the fingers, fixed in the part's frame.
        lp, lq = self._link_frame()
        tcp_pos, tcp_quat = robot.tcp_pose()
        inv = p.invertTransform(lp.tolist(), lq.tolist())
        tcp_in_link = p.multiplyTransforms(*inv, tcp_pos.tolist(), tcp_quat.tolist())
        held_quat = tcp_quat
        axis_local = np.asarray(
            p.getJointInfo(t.body_id, t.joint_index, physicsClientId=self._client)[13], float
        )
        q = q_held
        last = -math.inf
        for _ in range(2 * math.ceil(goal / step) + 4):
            opened = (world.joint_position(t) - q_start) * t.open_direction
            if opened >= goal - 1e-3 or opened - last < 0.1 * step:
                break  # far enough, or the part no longer follows the hand (blocked)
            last = opened
            amounts = (min(step, goal - opened + 1e-3), step / 2)
            q_next = self._follow(tcp_in_link, axis_local, held_quat, q, amounts)
            if q_next is None:
                break
            self._drive(q, q_next, PULL_WAYPOINTS, PULL_STEPS)
            q = q_next
            if self._lost_grip():
                break
        world.step(20)
        opened = (world.joint_position(t) - q_start) * t.open_direction
        if opened < need:
            self._why = "the part did not open far enough"
        return bool(opened >= need), float(opened)

    def _lost_grip(self) -> bool:
        """The tool let go of the part: the cup is off, or the fingers closed on nothing
        (the handle slipped out)."""
        tool = self.tool
        if isinstance(tool, SuctionTool):
            return not tool.holds(self.target.body_id)
        return tool.opening() < 0.002

    def _release(self) -> None:
        # Suction holds by a constraint: let go of the target before and after a trial.
        if isinstance(self.tool, SuctionTool):
            self.tool.off()

    # ---------------------------------------------------------------- trial
    def _place(self, x: float, y: float, yaw: float | None) -> list[int]:
        """Put the base at ``(x, y)`` facing the target (or ``yaw``), the arm at home;
        the scene bodies the base then collides with (empty: it fits)."""
        robot = self.robot
        assert self.world.configuration is not None  # loaded when the runner was made
        anchor = self.world.configuration.target.anchor
        if yaw is None:
            yaw = math.atan2(anchor[1] - y, anchor[0] - x)
        robot.place_base(x, y, yaw)
        robot.set_joint_positions(robot.home)
        half_diagonal = 0.5 * float(np.hypot(*robot.spec.footprint))
        return robot.base_collisions(self._near(x, y, half_diagonal + 0.02))

    def reset(self) -> None:
        """The world as it was before any trial (a trial moves the target, may open a door
        or push an object): what a camera must see before the next manipulation."""
        if self._dirty:
            self._restore()

    def base_free(self, x: float, y: float, yaw: float | None = None) -> bool:
        """Whether the base fits at ``(x, y)`` facing the target: the first check of
        :meth:`run`, without the rest of the trial."""
        if self._dirty:
            self._restore()
        return not self._place(x, y, yaw)

    def run(self, x: float, y: float, yaw: float | None = None) -> TrialResult:
        """One trial with the base at ``(x, y)`` facing the target (or ``yaw``)."""
        t0 = time.perf_counter()
        robot = self.robot
        self._release()
        if self._dirty:  # checks only teleport the robot; physics may have moved anything
            self._restore()
        hits = self._place(x, y, yaw)
        if hits:
            pairs = tuple(sorted(f"{BASE_LINK} with {self._name(b, -1)}" for b in hits))
            return TrialResult(Stage.BASE_COLLISION, t_check=time.perf_counter() - t0, why=pairs)
        arm_bodies = [self._floor, *self._near(x, y, robot.workspace()[1] + 0.5)]
        stage, plan, t_ik = self._plan(np.array([x, y]), arm_bodies)
        t1 = time.perf_counter()
        if plan is None:
            why: tuple[str, ...] = ()
            if stage == Stage.ARM_COLLISION:
                why = tuple(sorted(self._contacts))
            return TrialResult(
                stage, t_check=t1 - t0 - t_ik, t_ik=t_ik, why=why, ik_pose=self._ik_pose
            )
        self._dirty = True
        self._why = ""
        ok, moved = self._execute(plan)
        t2 = time.perf_counter()
        self._release()
        return TrialResult(
            Stage.SUCCESS if ok else Stage.EXECUTION_FAILED,
            moved,
            plan.grasp.name,
            t1 - t0 - t_ik,
            t_ik,
            t2 - t1,
            () if ok or not self._why else (self._why,),
        )
