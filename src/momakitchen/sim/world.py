"""Build a layout in a PyBullet DIRECT client and reset it to any configuration.

*Building* (room, furniture) happens once per :class:`World`; *initialising* a configuration
(objects on the counter, obstacles, articulated parts closed) is cheap and can be repeated.
Each world owns its own physics client, so several worlds coexist in one process.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pybullet_data

from momakitchen.assets import AssetModel, GraspFrame, get_category
from momakitchen.assets.cache import cached_urdf
from momakitchen.bullet import connect_direct, p
from momakitchen.errors import MomaError
from momakitchen.scene.configuration import Configuration
from momakitchen.scene.layout import Layout, Placed, scene_rng

TIME_STEP = 1.0 / 240.0
APPEARANCE_STREAM = 2  # seed stream for colours that the layout does not fix (walls, floor)


@dataclass
class BodyInfo:
    """A body in the world: who it is and how to address its links and joints."""

    uid: str
    category: str
    kind: str  # "structure" | "furniture" | "appliance" | "rigid" | "obstacle"
    body_id: int
    placed: Placed | None = None
    links: dict[str, int] = field(default_factory=dict)  # link name -> link index (-1 = base)
    joints: dict[str, int] = field(default_factory=dict)  # joint name -> joint index

    @property
    def model(self) -> AssetModel | None:
        return self.placed.model if self.placed is not None else None


@dataclass(frozen=True)
class TargetInfo:
    """The configuration's target as the simulator sees it.

    ``grasp`` is expressed in the frame of link ``link_index`` of ``body_id``; for an
    articulated target ``joint_index`` is the joint to open, ``open_direction`` its sign
    and ``limit`` its travel (rad or m).
    """

    body_id: int
    link_index: int
    category: str
    part: str  # "object" for rigid targets, else the articulated part ("door", ...)
    grasp: GraspFrame
    joint_index: int | None = None
    joint_type: str | None = None
    open_direction: int = 1
    limit: float = 0.0

    @property
    def is_articulated(self) -> bool:
        return self.joint_index is not None


def _quat_z(yaw: float) -> tuple[float, float, float, float]:
    return (0.0, 0.0, float(np.sin(yaw / 2)), float(np.cos(yaw / 2)))


class World:
    """A kitchen built in its own PyBullet DIRECT client.

    Example::

        world = World(sample_layout(7))
        world.load_configuration(scene.configurations[0])
        target = world.target
        pos, normal, closing = world.grasp_in_world()
    """

    def __init__(self, layout: Layout) -> None:
        self.layout = layout
        self._client: int | None = connect_direct()
        self.bodies: dict[str, BodyInfo] = {}
        self.configuration: Configuration | None = None
        self._config_uids: list[str] = []
        try:
            p.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=self.client)
            p.setGravity(0, 0, -9.81, physicsClientId=self.client)
            p.setTimeStep(TIME_STEP, physicsClientId=self.client)
            # Sorted contact pairs: results must not depend on memory layout.
            p.setPhysicsEngineParameter(
                deterministicOverlappingPairs=1, physicsClientId=self.client
            )
            for placed in layout.furniture:
                self._load(placed)
            # The room last: TinyRenderer draws bodies in load order and shades every
            # fragment that passes the depth test, so walls and floor drawn after the
            # furniture skip the pixels it hides (frames ~12 % faster, same images).
            self._build_room()
        except BaseException:
            self.close()
            raise

    # -- building -------------------------------------------------------------------------
    def _build_room(self) -> None:
        c, room = self.client, self.layout.room
        rng = scene_rng(self.layout.scene_id, APPEARANCE_STREAM)
        tone = rng.uniform(0.45, 0.8)
        # Collision: a 200 m slab (as pybullet_data's plane.urdf). Visual: a 5 mm slab the
        # size of the room; the renderer's cost grows with the screen area a triangle spans,
        # and plane.urdf's 100 m visual made the floor cost a quarter of every frame.
        col = p.createCollisionShape(
            p.GEOM_BOX,
            halfExtents=[100, 100, 5],
            collisionFramePosition=[0, 0, -5],
            physicsClientId=c,
        )
        vis = p.createVisualShape(
            p.GEOM_BOX,
            halfExtents=[room.width / 2, room.depth / 2, 0.0025],
            visualFramePosition=[room.width / 2, room.depth / 2, -0.0025],
            rgbaColor=[tone, tone * 0.92, tone * 0.8, 1],
            physicsClientId=c,
        )
        floor = p.createMultiBody(0, col, vis, physicsClientId=c)
        p.changeDynamics(floor, -1, lateralFriction=1.0, physicsClientId=c)
        self.bodies["floor"] = BodyInfo("floor", "floor", "structure", floor)
        wall_rgba = [*rng.uniform(0.75, 0.95, size=3).tolist(), 1.0]
        t, h = 0.1, room.wall_height
        walls = {  # name: (centre xy, half extents xy)
            "wall_back": ((room.width / 2, -t / 2), (room.width / 2 + t, t / 2)),
            "wall_left": ((-t / 2, room.depth / 2), (t / 2, room.depth / 2)),
            "wall_right": ((room.width + t / 2, room.depth / 2), (t / 2, room.depth / 2)),
            "wall_front": ((room.width / 2, room.depth + t / 2), (room.width / 2 + t, t / 2)),
        }
        for name, ((x, y), (hx, hy)) in walls.items():
            col = p.createCollisionShape(p.GEOM_BOX, halfExtents=[hx, hy, h / 2], physicsClientId=c)
            vis = p.createVisualShape(
                p.GEOM_BOX, halfExtents=[hx, hy, h / 2], rgbaColor=wall_rgba, physicsClientId=c
            )
            body = p.createMultiBody(0, col, vis, basePosition=[x, y, h / 2], physicsClientId=c)
            self.bodies[name] = BodyInfo(name, "wall", "structure", body)

    def _load(self, placed: Placed) -> BodyInfo:
        model = placed.model
        kind = get_category(placed.category).kind
        # External assets are loaded from their own folder (meshes are relative to it).
        path = model.path or str(cached_urdf(model.urdf, placed.category))
        fixed = kind in ("furniture", "appliance")
        try:
            body = p.loadURDF(
                path,
                basePosition=[placed.x, placed.y, placed.z],
                baseOrientation=_quat_z(placed.yaw),
                useFixedBase=fixed,
                globalScaling=float(model.scale),
                flags=p.URDF_USE_INERTIA_FROM_FILE,
                physicsClientId=self.client,
            )
        except p.error as exc:
            raise MomaError(f"cannot load {placed.category} asset {path!r}: {exc}") from None
        info = BodyInfo(placed.uid, placed.category, kind, body, placed)
        info.links[p.getBodyInfo(body, physicsClientId=self.client)[0].decode()] = -1
        for j in range(p.getNumJoints(body, physicsClientId=self.client)):
            ji = p.getJointInfo(body, j, physicsClientId=self.client)
            info.joints[ji[1].decode()] = j
            info.links[ji[12].decode()] = j
            if ji[2] in (p.JOINT_REVOLUTE, p.JOINT_PRISMATIC):
                # PyBullet drives joints with a velocity motor by default: turn it into the
                # joint's dry friction so that parts move when pulled but do not swing freely.
                friction = max(float(ji[7]), 0.05)
                p.setJointMotorControl2(
                    body,
                    j,
                    p.VELOCITY_CONTROL,
                    targetVelocity=0,
                    force=friction,
                    physicsClientId=self.client,
                )
        self.bodies[placed.uid] = info
        return info

    # -- configurations -------------------------------------------------------------------
    def load_configuration(self, cfg: Configuration) -> None:
        """Reset the world to ``cfg``: remove the previous objects and obstacles, close every
        articulated part and place the new objects and obstacles."""
        if cfg.scene_id != self.layout.scene_id:
            raise MomaError(
                f"configuration of scene {cfg.scene_id} cannot be loaded into scene "
                f"{self.layout.scene_id}"
            )
        for uid in self._config_uids:
            p.removeBody(self.bodies.pop(uid).body_id, physicsClientId=self.client)
        self._config_uids = []
        for info in self.bodies.values():
            for j in info.joints.values():
                p.resetJointState(info.body_id, j, 0.0, 0.0, physicsClientId=self.client)
        for placed in (*cfg.objects, *cfg.obstacles):
            self._load(placed)
            self._config_uids.append(placed.uid)
        self.configuration = cfg

    @property
    def target(self) -> TargetInfo:
        """The loaded configuration's target."""
        if self.configuration is None:
            raise MomaError("no configuration loaded")
        t = self.configuration.target
        info = self.bodies[t.uid]
        model = info.model
        assert model is not None  # configuration targets are placed assets, not structure
        if t.articulation is None:
            grasp = model.grasps[0]
            return TargetInfo(
                info.body_id,
                info.links[grasp.link] if grasp.link in info.links else -1,
                t.category,
                "object",
                grasp,
            )
        art = model.articulations[t.articulation]
        return TargetInfo(
            info.body_id,
            info.links[art.handle.link],
            t.category,
            art.part,
            art.handle,
            info.joints[art.joint],
            art.joint_type,
            art.open_direction,
            art.limit,
        )

    def link_pose(self, body_id: int, link_index: int) -> tuple[np.ndarray, np.ndarray]:
        """World position (3,) and rotation matrix (3, 3) of a link's URDF frame."""
        c = self.client
        if link_index == -1:
            pos, orn = p.getBasePositionAndOrientation(body_id, physicsClientId=c)
            # The base pose is that of its inertial frame; move back to the URDF link frame.
            dyn = p.getDynamicsInfo(body_id, -1, physicsClientId=c)
            inv_pos, inv_orn = p.invertTransform(dyn[3], dyn[4])
            pos, orn = p.multiplyTransforms(pos, orn, inv_pos, inv_orn)
        else:
            state = p.getLinkState(
                body_id, link_index, computeForwardKinematics=True, physicsClientId=c
            )
            pos, orn = state[4], state[5]
        rot = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3)
        return np.array(pos), rot

    def grasp_in_world(self, target: TargetInfo | None = None) -> tuple[np.ndarray, ...]:
        """Current world grasp point (3,), outward normal (3,) and closing axis (3,)."""
        target = target or self.target
        pos, rot = self.link_pose(target.body_id, target.link_index)
        g = target.grasp
        return (
            rot @ np.asarray(g.position) + pos,
            rot @ np.asarray(g.normal),
            rot @ np.asarray(g.closing_axis),
        )

    def joint_position(self, target: TargetInfo | None = None) -> float:
        """Current position of the target's joint (articulated targets only)."""
        target = target or self.target
        if target.joint_index is None:
            raise MomaError("the target is a rigid object: it has no joint")
        return float(
            p.getJointState(target.body_id, target.joint_index, physicsClientId=self.client)[0]
        )

    # -- physics --------------------------------------------------------------------------
    def step(self, n: int = 1) -> None:
        for _ in range(n):
            p.stepSimulation(physicsClientId=self.client)

    def save_state(self) -> int:
        return p.saveState(physicsClientId=self.client)

    def restore_state(self, state_id: int) -> None:
        p.restoreState(stateId=state_id, physicsClientId=self.client)

    def body_ids(self, kinds: tuple[str, ...] | None = None) -> list[int]:
        """Body ids of the bodies of the given kinds (all if None), in load order."""
        return [b.body_id for b in self.bodies.values() if kinds is None or b.kind in kinds]

    def aabb(self, body_id: int) -> np.ndarray:
        """Axis-aligned bounding box of a whole body (all links). Shape (2, 3): min, max."""
        c = self.client
        boxes = [
            p.getAABB(body_id, link, physicsClientId=c)
            for link in range(-1, p.getNumJoints(body_id, physicsClientId=c))
        ]
        lo = np.min([b[0] for b in boxes], axis=0)
        hi = np.max([b[1] for b in boxes], axis=0)
        return np.stack([lo, hi])

    def penetrations(self, tolerance: float = 1e-3) -> list[tuple[str, str, float]]:
        """Pairs of bodies that interpenetrate by more than ``tolerance`` (m), with depth.

        Static/static pairs are included (PyBullet's broadphase skips them during stepping,
        so they are queried explicitly). Floor contacts of resting objects do not count.
        """
        infos = list(self.bodies.values())
        found = []
        for i, a in enumerate(infos):
            for b in infos[i + 1 :]:
                pts = p.getClosestPoints(
                    a.body_id, b.body_id, distance=0.0, physicsClientId=self.client
                )
                depth = min((pt[8] for pt in pts), default=0.0)
                if depth < -tolerance:
                    found.append((a.uid, b.uid, float(depth)))
        return found

    @property
    def client(self) -> int:
        """The PyBullet client id (a closed world has none)."""
        if self._client is None:
            raise MomaError("the world is closed")
        return self._client

    def close(self) -> None:
        if self._client is not None and p.isConnected(self._client):
            p.disconnect(self._client)
        self._client = None

    def __enter__(self) -> World:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
