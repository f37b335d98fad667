"""RGB-D frames from a recorded ROS 2 bag: images, camera info and the TF tree.

A bag is a directory written by ``ros2 bag record`` (``.db3`` or ``.mcap`` storage, with its
``metadata.yaml``) or a single ``.mcap`` file. For every selected depth frame this module
decodes the depth image (``16UC1`` millimetres with 0 invalid, or ``32FC1`` metres with NaN
invalid; also ``16UC1`` ``compressedDepth`` PNG), pairs it with the colour image and the
masks nearest in time (by ``header.stamp``, within ``max_dt``), takes the intrinsics from
the nearest ``sensor_msgs/CameraInfo`` and composes the camera-to-base transform from
``/tf_static`` and ``/tf`` at the depth frame's stamp (and, when asked, the base's pose in
the odometry frame). The camera frame is the depth image's ``header.frame_id``: a camera's
optical frame (REP 103: x right, y down, z forward), which is the OpenCV convention
:func:`momakitchen.predict` takes. The base frame must follow REP 105 with z = 0 on the
floor (``base_footprint`` where ``base_link`` sits above the floor).

With an odometry frame, the base may move between two consecutive selected frames at most
:data:`ODOM_MAX_SPEED` (2 m/s) times the time between their stamps, plus
:data:`ODOM_SLACK` (0.5 m): odometry that jumps further (a reset, a relocalisation, a
broken sample) would fuse one scene into several islands, so it is refused naming both
frames and the jump.

Every selected frame is read and checked before a single prediction runs, so a bad bag
costs no model time and leaves nothing behind. Reading needs the ``robot`` extra
(``rosbags``).
"""

from __future__ import annotations

import math
import os
from collections import defaultdict
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from itertools import pairwise
from pathlib import Path
from typing import Any

import numpy as np

from momakitchen.deploy.bagchecks import check_frame_images, intrinsics_of
from momakitchen.deploy.bagimages import colour_rgb, depth_metres, mask_image
from momakitchen.deploy.bagread import (
    CAMERA_INFO,
    COMPRESSED,
    IMAGE,
    TF_MESSAGE,
    TF_TOPICS,
    Stream,
    check_bag_path,
    header_of,
    open_error,
    stamp_ns,
    typestore,
)
from momakitchen.deploy.bagtf import TransformBuffer, planar_pose
from momakitchen.errors import MomaError

# The fastest a mobile base plausibly drives between two frames (mobile manipulators drive
# at about 1 m/s), and the slack for odometry noise and stamps taken at once.
ODOM_MAX_SPEED = 2.0  # m/s
ODOM_SLACK = 0.5  # m


# ---------------------------------------------------------------------------- options
@dataclass(frozen=True)
class BagTopics:
    """Which topics and frames of a bag make a frame.

    ``target_mask`` and ``obstacle_masks`` name mono8 image topics (e.g. a segmenter node's
    output); without ``target_mask`` the caller supplies a mask. ``max_dt`` (s) is the
    largest stamp difference between the depth frame and the colour / mask message paired
    with it. ``odom_frame`` (e.g. ``odom``): also look up the base's pose in that frame at
    every selected frame's stamp (:attr:`BagFrame.odom_pose`), to fuse the frames' maps;
    ``max_odom_speed`` (m/s): between two consecutive selected frames the base may move
    at most this fast, plus :data:`ODOM_SLACK`, or the odometry is refused as a jump.
    """

    depth: str
    camera_info: str
    rgb: str | None = None
    target_mask: str | None = None
    obstacle_masks: tuple[str, ...] = ()
    base_frame: str = "base_link"
    max_dt: float = 0.05
    odom_frame: str | None = None
    max_odom_speed: float = ODOM_MAX_SPEED

    def __post_init__(self) -> None:
        for name in ("depth", "camera_info", "base_frame"):
            if not getattr(self, name):
                raise MomaError(f"{name} must be a non-empty name")
        if not (np.isfinite(self.max_dt) and 0 < self.max_dt <= 10):
            raise MomaError(f"max_dt must be in (0, 10] s, got {self.max_dt}")
        if not (np.isfinite(self.max_odom_speed) and 0 < self.max_odom_speed <= 100):
            raise MomaError(f"max_odom_speed must be in (0, 100] m/s, got {self.max_odom_speed}")
        if self.odom_frame is not None and (
            not self.odom_frame.lstrip("/")
            or self.odom_frame.lstrip("/") == self.base_frame.lstrip("/")
        ):
            raise MomaError(
                f"the odometry frame must be a frame other than the base frame "
                f"{self.base_frame!r}, got {self.odom_frame!r}"
            )
        object.__setattr__(self, "obstacle_masks", tuple(self.obstacle_masks))

    def image_topics(self) -> dict[str, str]:
        """Role -> topic of the image streams paired with the depth frame."""
        roles = {"rgb": self.rgb, "target mask": self.target_mask}
        roles.update({f"obstacle mask {i}": t for i, t in enumerate(self.obstacle_masks)})
        return {role: topic for role, topic in roles.items() if topic}


@dataclass
class BagFrame:
    """One depth frame of a bag with everything :func:`momakitchen.predict` takes.

    Shapes: ``depth`` (H, W) float32 metres (0 or NaN invalid); ``rgb`` (H, W, 3) uint8 or
    None; masks (H, W) bool; ``camera_to_base`` (4, 4). ``odom_pose``: the base's
    ``(x, y, yaw)`` in the odometry frame at the frame's stamp, when asked for.
    """

    index: int  # of the depth message in the bag (0 = first)
    stamp_ns: int  # header.stamp of the depth image
    camera_frame: str
    base_frame: str
    depth: np.ndarray
    intrinsics: tuple[float, float, float, float]
    camera_to_base: np.ndarray
    rgb: np.ndarray | None = None
    target_mask: np.ndarray | None = None
    obstacle_masks: list[np.ndarray] = field(default_factory=list)
    paired_ns: dict[str, int] = field(default_factory=dict)  # role -> stamp used
    odom_pose: tuple[float, float, float] | None = None

    @property
    def stamp(self) -> float:
        return self.stamp_ns * 1e-9

    def summary(self) -> dict[str, Any]:
        """The frame's provenance, JSON-ready."""
        doc = {
            "index": self.index,
            "stamp": round(self.stamp, 9),
            "camera_frame": self.camera_frame,
            "base_frame": self.base_frame,
            "intrinsics": [round(v, 6) for v in self.intrinsics],
            "camera_to_base": np.round(self.camera_to_base, 9).tolist(),
            "paired_dt": {
                role: round((ns - self.stamp_ns) * 1e-9, 6) for role, ns in self.paired_ns.items()
            },
        }
        if self.odom_pose is not None:
            doc["odom_pose"] = [round(v, 6) for v in self.odom_pose]
        return doc


def frame_label(index: int, stamp_ns: int) -> str:
    """How errors name a depth frame: its index in the bag and its stamp."""
    return f"depth frame {index} at t={stamp_ns * 1e-9:.3f} s"


def check_odometry_steps(frames: Sequence[Any], max_speed: float = ODOM_MAX_SPEED) -> None:
    """MomaError naming the first two consecutive ``frames`` (each with ``index``,
    ``stamp_ns`` and ``odom_pose``) between which the base moved further than
    ``max_speed`` (m/s) times the time between them plus :data:`ODOM_SLACK`: odometry
    that jumps would fuse one scene into several islands."""
    for a, b in pairwise(frames):
        if a.odom_pose is None or b.odom_pose is None:
            continue
        step = math.hypot(b.odom_pose[0] - a.odom_pose[0], b.odom_pose[1] - a.odom_pose[1])
        seconds = abs(b.stamp_ns - a.stamp_ns) * 1e-9
        limit = max_speed * seconds + ODOM_SLACK
        if step > limit:
            raise MomaError(
                f"the odometry jumps {step:.2f} m between {frame_label(a.index, a.stamp_ns)} "
                f"and {frame_label(b.index, b.stamp_ns)}, {seconds:.3f} s apart: more than "
                f"a base drives ({max_speed:g} m/s, plus {ODOM_SLACK:g} m, allows "
                f"{limit:.2f} m), so their maps cannot be fused; check the odometry"
            )


@dataclass
class _Planned:
    """A selected depth frame, paired and placed before any image is decoded."""

    index: int
    stamp_ns: int
    camera: str
    intrinsics: tuple[float, float, float, float]
    info_shape: tuple[int, int]  # (height, width) of the camera info used
    camera_to_base: np.ndarray
    pairs: dict[str, int]  # role -> message index on its topic
    odom_pose: tuple[float, float, float] | None


# ---------------------------------------------------------------------------- the bag
class BagFrames:
    """The selected depth frames of a bag, every one checked on opening, then decoded one
    by one.

    Opening reads the bag once without decoding images: the topics and their types, the
    pairing of every selected frame within ``topics.max_dt``, the camera info and the TF
    path (and odometry pose) at every selected frame's stamp. It then decodes every
    selected frame's images once and checks them (encodings, sizes against each other and
    the camera info, a depth image with valid pixels, a target mask with pixels of valid
    depth), keeping none, so any error is raised here, before the model runs, naming the
    frame. Iterating reads the bag again and yields each frame as soon as its messages
    have been seen, so memory stays bounded however many frames are selected. Use as a
    context manager (or call :meth:`close`).

    Args:
        path: a bag directory (``.db3`` or ``.mcap`` storage) or a single ``.mcap`` file.
        topics: the topics and frames to use.
        time: the depth frame recorded nearest this many seconds after the bag's start
            (as ``ros2 bag play --start-offset``).
        every: every ``every``-th depth frame, from the first. Exactly one of ``time`` and
            ``every`` is given.
        target_mask: one (H, W) mask, or a mask file, for every frame, where
            ``topics.target_mask`` names no topic (checked against every frame too).
    """

    def __init__(
        self,
        path: str | Path,
        topics: BagTopics,
        *,
        time: float | None = None,
        every: int | None = None,
        target_mask: Any = None,
    ) -> None:
        if (time is None) == (every is None):
            raise MomaError("choose the frames with either a time or every N frames")
        if every is not None and every < 1:
            raise MomaError(f"every must be >= 1, got {every}")
        if time is not None and not (np.isfinite(time) and time >= 0):
            raise MomaError(f"time must be a number of seconds >= 0, got {time}")
        if target_mask is not None and topics.target_mask is not None:
            raise MomaError("give the target mask either as a mask topic or as a mask, not both")
        self.path = check_bag_path(path)
        self.topics = topics
        self.mask: np.ndarray | None = None
        self.mask_source = "given"
        if target_mask is not None:
            from momakitchen.deploy.predict import load_mask

            self.mask = load_mask(target_mask, "target mask")
            if isinstance(target_mask, (str, os.PathLike)):
                self.mask_source = f"from {str(target_mask)!r}"
        self.store = typestore()
        from rosbags.rosbag2 import Reader

        try:
            self.reader = Reader(self.path)
            self.reader.open()
        except Exception as exc:  # the library raises its own, sqlite's and yaml's errors
            raise open_error(self.path, exc) from None
        try:
            self.planned = self._plan(time, every)
            for _ in self._assemble():  # decode and check every frame; keep none
                pass
        except BaseException:
            self.close()
            raise

    def __len__(self) -> int:
        return len(self.planned)

    def close(self) -> None:
        if self.reader.is_open:
            self.reader.close()

    def __enter__(self) -> BagFrames:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _messages(self, topics: set[str]) -> Iterator[tuple[Any, int, Any]]:
        conns = [c for c in self.reader.connections if c.topic in topics]
        it = iter(self.reader.messages(connections=conns))
        while True:
            try:
                item = next(it)
            except StopIteration:
                return
            except Exception as exc:
                raise open_error(self.path, exc) from None
            yield item

    def _deserialize(self, raw: Any, msgtype: str) -> Any:
        try:
            return self.store.deserialize_cdr(raw, msgtype)
        except Exception as exc:
            raise open_error(self.path, exc) from None

    def _decode(self, role: str, topic: str, msgtype: str, raw: Any) -> np.ndarray:
        msg = self._deserialize(raw, msgtype)
        if role == "depth":
            return depth_metres(msg, msgtype, topic)
        if role == "rgb":
            return colour_rgb(msg, msgtype, topic)
        return mask_image(msg, msgtype, topic)

    def _check_topics(self, available: dict[str, str]) -> None:
        topics = self.topics
        wanted = {"depth": topics.depth, **topics.image_topics(), "camera info": topics.camera_info}
        listing = ", ".join(f"{t} ({m})" for t, m in sorted(available.items())) or "none"
        for role, topic in wanted.items():
            if topic not in available:
                raise MomaError(f"{role} topic {topic!r} is not in the bag; its topics: {listing}")
            types = (CAMERA_INFO,) if role == "camera info" else (IMAGE, COMPRESSED)
            if available[topic] not in types:
                raise MomaError(
                    f"{role} topic {topic!r} has type {available[topic]}, expected "
                    f"{' or '.join(types)}"
                )
        for t in TF_TOPICS:
            if t in available and available[t] != TF_MESSAGE:
                raise MomaError(f"topic {t!r} has type {available[t]}, expected {TF_MESSAGE}")

    def _plan(self, time: float | None, every: int | None) -> list[_Planned]:
        topics = self.topics
        available = {c.topic: c.msgtype for c in self.reader.connections}
        self._check_topics(available)
        images = {"depth": topics.depth, **topics.image_topics()}
        tf_topics = [t for t in TF_TOPICS if t in available]

        # One pass: image headers only, camera info and TF in full.
        self.streams = streams = {t: Stream(t, available[t]) for t in images.values()}
        frame_ids: list[str] = []
        infos: list[tuple[int, Any]] = []
        tf = TransformBuffer()
        for conn, log_ns, raw in self._messages({*streams, topics.camera_info, *tf_topics}):
            if conn.topic in tf_topics:
                for ts in self._deserialize(raw, TF_MESSAGE).transforms:
                    tf.add(
                        ts.header.frame_id,
                        ts.child_frame_id,
                        stamp_ns(ts.header.stamp),
                        ts.transform,
                        static=conn.topic == "/tf_static",
                    )
            if conn.topic == topics.camera_info:
                info = self._deserialize(raw, CAMERA_INFO)
                infos.append((stamp_ns(info.header.stamp), info))
            if conn.topic in streams:
                stream = streams[conn.topic]
                stamp, frame_id = header_of(raw, conn.topic)
                stream.log_ns.append(log_ns)
                stream.stamp_ns.append(stamp)
                if conn.topic == topics.depth:
                    frame_ids.append(frame_id)

        for role, topic in images.items():
            if not streams[topic].stamp_ns:
                raise MomaError(f"{role} topic {topic!r} has no message in the bag")
        if not infos:
            raise MomaError(f"camera info topic {topics.camera_info!r} has no message in the bag")
        depth = streams[topics.depth]
        if time is not None:
            start = int(self.reader.start_time)
            offsets = (np.asarray(depth.log_ns, np.int64) - start) * 1e-9
            duration = (int(self.reader.end_time) - start) * 1e-9
            if time > duration + 1.0:
                raise MomaError(
                    f"time {time:g} s is past the end of the bag ({duration:.3f} s long)"
                )
            selected = [int(np.argmin(np.abs(offsets - time)))]
        else:
            assert every is not None
            selected = list(range(0, len(depth.stamp_ns), every))
        info_stamps = np.asarray([s for s, _ in infos], np.int64)
        planned = []
        for index in selected:
            stamp = depth.stamp_ns[index]
            try:
                info = infos[int(np.argmin(np.abs(info_stamps - stamp)))][1]
                planned.append(self._place(index, stamp, frame_ids[index], info, tf))
            except MomaError as exc:
                raise MomaError(f"{frame_label(index, stamp)}: {exc}") from None
        if topics.odom_frame is not None:
            check_odometry_steps(planned, topics.max_odom_speed)
        return planned

    def _place(self, index: int, stamp: int, frame_id: str, info: Any, tf: Any) -> _Planned:
        """Pair one selected depth frame and place it in the TF tree (no image decoded)."""
        topics = self.topics
        pairs = {}
        for role, topic in topics.image_topics().items():
            j = self.streams[topic].nearest(stamp)
            dt = (self.streams[topic].stamp_ns[j] - stamp) * 1e-9
            if abs(dt) > topics.max_dt:
                raise MomaError(
                    f"no {role} message on {topic!r} within {topics.max_dt:g} s of the depth "
                    f"image (the nearest is {abs(dt):.3f} s away); raise --max-dt or record "
                    "the topics together"
                )
            pairs[role] = j
        camera = (frame_id or info.header.frame_id).lstrip("/")
        if not camera:
            raise MomaError(f"depth topic {topics.depth!r}: the image has no header.frame_id")
        camera_to_base = tf.lookup(topics.base_frame, camera, stamp)
        if not np.isfinite(camera_to_base).all():
            raise MomaError(f"the TF from {camera!r} to {topics.base_frame!r} is not finite")
        odom_pose = None
        if topics.odom_frame is not None:
            try:
                odom = tf.lookup(topics.odom_frame, topics.base_frame, stamp, "the base frame")
            except MomaError as exc:
                raise MomaError(f"no odometry pose: {exc}") from None
            odom_pose = planar_pose(odom)
            if not np.isfinite(odom_pose).all():
                raise MomaError(f"the odometry pose {odom_pose} is not finite")
        return _Planned(
            index=index,
            stamp_ns=stamp,
            camera=camera,
            intrinsics=intrinsics_of(info, topics.camera_info),
            info_shape=(int(info.height), int(info.width)),
            camera_to_base=camera_to_base,
            pairs=pairs,
            odom_pose=odom_pose,
        )

    def __iter__(self) -> Iterator[BagFrame]:
        """The planned frames, each yielded once all its messages have been read."""
        return self._assemble()

    def _assemble(self) -> Iterator[BagFrame]:
        topics = self.topics
        roles = {"depth": topics.depth, **topics.image_topics()}
        users: dict[tuple[str, int], list[tuple[_Planned, str]]] = defaultdict(list)
        for plan in self.planned:
            users[(topics.depth, plan.index)].append((plan, "depth"))
            for role, j in plan.pairs.items():
                users[(roles[role], j)].append((plan, role))
        parts: dict[int, dict[str, np.ndarray]] = defaultdict(dict)
        counters: dict[str, int] = defaultdict(int)
        for conn, _, raw in self._messages({key[0] for key in users}):
            j = counters[conn.topic]
            counters[conn.topic] += 1
            decoded: dict[str, np.ndarray] = {}
            for plan, role in users.pop((conn.topic, j), []):
                kind = role if role in ("depth", "rgb") else "mask"
                if kind not in decoded:
                    try:
                        decoded[kind] = self._decode(role, conn.topic, conn.msgtype, raw)
                    except MomaError as exc:
                        raise MomaError(
                            f"{frame_label(plan.index, plan.stamp_ns)}: {exc}"
                        ) from None
                parts[plan.index][role] = decoded[kind]
                if len(parts[plan.index]) == len(plan.pairs) + 1:
                    yield self._frame(plan, parts.pop(plan.index))

    def _frame(self, plan: _Planned, parts: dict[str, np.ndarray]) -> BagFrame:
        topics = self.topics
        sources = {role: f"on {topic!r}" for role, topic in topics.image_topics().items()}
        sources["depth"] = f"on {topics.depth!r}"
        if self.mask is not None:
            parts = {**parts, "target mask": self.mask}
            sources["target mask"] = self.mask_source
        try:
            check_frame_images(parts, sources, plan.info_shape, topics.camera_info)
        except MomaError as exc:
            raise MomaError(f"{frame_label(plan.index, plan.stamp_ns)}: {exc}") from None
        return BagFrame(
            index=plan.index,
            stamp_ns=plan.stamp_ns,
            camera_frame=plan.camera,
            base_frame=topics.base_frame,
            depth=parts["depth"],
            intrinsics=plan.intrinsics,
            camera_to_base=plan.camera_to_base,
            rgb=parts.get("rgb"),
            target_mask=parts.get("target mask"),
            obstacle_masks=[parts[f"obstacle mask {i}"] for i in range(len(topics.obstacle_masks))],
            paired_ns={
                role: self.streams[topics.image_topics()[role]].stamp_ns[j]
                for role, j in plan.pairs.items()
            },
            odom_pose=plan.odom_pose,
        )


def read_bag_frames(
    path: str | Path,
    topics: BagTopics,
    *,
    time: float | None = None,
    every: int | None = None,
    target_mask: Any = None,
) -> list[BagFrame]:
    """All the selected frames of a bag at once (see :class:`BagFrames`, which yields
    them one by one)."""
    with BagFrames(path, topics, time=time, every=every, target_mask=target_mask) as frames:
        return list(frames)
