"""RGB-D frames from a recorded ROS 2 bag: images, camera info and the TF tree.

A bag is a directory written by ``ros2 bag record`` (``.db3`` or ``.mcap`` storage, with its
``metadata.yaml``) or a single ``.mcap`` file. For every selected depth frame this module
decodes the depth image (``16UC1`` millimetres with 0 invalid, or ``32FC1`` metres with NaN
invalid; also ``16UC1`` ``compressedDepth`` PNG), pairs it with the colour image and the
masks nearest in time (by ``header.stamp``, within ``max_dt``), takes the intrinsics from
the nearest ``sensor_msgs/CameraInfo`` and composes the camera-to-base transform from
``/tf_static`` and ``/tf`` at the depth frame's stamp. The camera frame is the depth
image's ``header.frame_id``: a camera's optical frame (REP 103: x right, y down, z
forward), which is the OpenCV convention :func:`momakitchen.predict` takes. The base frame
must follow REP 105 with z = 0 on the floor (``base_footprint`` where ``base_link`` sits
above the floor).

Everything is read and checked before a single prediction runs, so a bad bag costs no
model time and leaves nothing behind. Reading needs the ``robot`` extra (``rosbags``).
"""

from __future__ import annotations

import io
import struct
from collections import defaultdict, deque
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from momakitchen.errors import MomaError

TF_TOPICS = ("/tf_static", "/tf")
IMAGE = "sensor_msgs/msg/Image"
COMPRESSED = "sensor_msgs/msg/CompressedImage"
CAMERA_INFO = "sensor_msgs/msg/CameraInfo"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"
DEPTH_ENCODINGS = ("16UC1", "mono16", "32FC1")
RGB_ENCODINGS = ("rgb8", "bgr8", "rgba8", "bgra8", "mono8")
MASK_ENCODINGS = ("mono8", "8UC1", "mono16", "16UC1")
# Seconds a /tf sample may lie outside the span of a dynamic transform's samples and still
# be used (tf2 itself never extrapolates; a robot state publisher at 30 Hz leaves gaps of
# 33 ms before the first and after the last sample).
TF_EDGE_TOLERANCE = 0.05


def typestore() -> Any:
    """The ROS 2 (Humble) message types of ``rosbags``; MomaError when it is missing."""
    try:
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise MomaError(
            "reading and writing ROS 2 bags needs the robot extra: pip install -e '.[robot]'"
        ) from None
    return get_typestore(Stores.ROS2_HUMBLE)


# ---------------------------------------------------------------------------- options
@dataclass(frozen=True)
class BagTopics:
    """Which topics and frames of a bag make a frame.

    ``target_mask`` and ``obstacle_masks`` name mono8 image topics (e.g. a segmenter node's
    output); without ``target_mask`` the caller supplies a mask. ``max_dt`` (s) is the
    largest stamp difference between the depth frame and the colour / mask message paired
    with it.
    """

    depth: str
    camera_info: str
    rgb: str | None = None
    target_mask: str | None = None
    obstacle_masks: tuple[str, ...] = ()
    base_frame: str = "base_link"
    max_dt: float = 0.05

    def __post_init__(self) -> None:
        for name in ("depth", "camera_info", "base_frame"):
            if not getattr(self, name):
                raise MomaError(f"{name} must be a non-empty name")
        if not (np.isfinite(self.max_dt) and 0 < self.max_dt <= 10):
            raise MomaError(f"max_dt must be in (0, 10] s, got {self.max_dt}")
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
    None; masks (H, W) bool; ``camera_to_base`` (4, 4).
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

    @property
    def stamp(self) -> float:
        return self.stamp_ns * 1e-9

    def summary(self) -> dict[str, Any]:
        """The frame's provenance, JSON-ready."""
        return {
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


# ---------------------------------------------------------------------------- images
def _stamp_ns(stamp: Any) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def image_array(msg: Any, topic: str) -> np.ndarray:
    """The pixels of a ``sensor_msgs/Image`` as (H, W) or (H, W, C), honouring ``step``
    (row padding) and ``is_bigendian``."""
    enc = msg.encoding
    layouts = {
        "rgb8": (np.uint8, 3),
        "bgr8": (np.uint8, 3),
        "rgba8": (np.uint8, 4),
        "bgra8": (np.uint8, 4),
        "mono8": (np.uint8, 1),
        "8UC1": (np.uint8, 1),
        "mono16": (np.uint16, 1),
        "16UC1": (np.uint16, 1),
        "32FC1": (np.float32, 1),
    }
    if enc not in layouts:
        raise MomaError(f"topic {topic!r}: unknown image encoding {enc!r}")
    dtype, channels = layouts[enc]
    h, w = int(msg.height), int(msg.width)
    item = np.dtype(dtype).itemsize
    row = w * channels * item
    data = np.asarray(msg.data, np.uint8).reshape(-1)
    if h == 0 or w == 0 or msg.step < row or data.size < msg.step * (h - 1) + row:
        raise MomaError(
            f"topic {topic!r}: image data of {data.size} bytes does not hold {w}x{h} "
            f"{enc} pixels with step {msg.step}"
        )
    rows = np.lib.stride_tricks.as_strided(data, (h, row), (msg.step, 1))
    stored = np.dtype(dtype).newbyteorder(">" if msg.is_bigendian else "<")
    pixels = np.ascontiguousarray(rows).view(stored)
    pixels = pixels.reshape(h, w, channels).astype(dtype)
    return pixels[..., 0] if channels == 1 else pixels


def _compressed_array(msg: Any, topic: str) -> np.ndarray:
    """Decode a ``CompressedImage`` (JPEG / PNG, or a 16UC1 ``compressedDepth`` PNG)."""
    from PIL import Image, UnidentifiedImageError

    fmt = str(msg.format)
    data = bytes(np.asarray(msg.data, np.uint8))
    if "compresseddepth" in fmt.lower().replace(" ", ""):
        if not fmt.lower().startswith(("16uc1", "mono16")) or "png" not in fmt.lower():
            raise MomaError(
                f"topic {topic!r}: compressed depth format {fmt!r} is not supported "
                "(use raw 16UC1 / 32FC1 images or '16UC1; compressedDepth png')"
            )
        data = data[12:]  # compressed_depth_image_transport's config header
    try:
        with Image.open(io.BytesIO(data)) as img:
            if img.format not in ("JPEG", "PNG"):
                raise MomaError(f"topic {topic!r}: compressed image is {img.format}, not JPEG/PNG")
            if img.mode in ("RGBA", "P", "LA", "CMYK", "YCbCr"):
                return np.array(img.convert("RGB"))
            return np.array(img)
    except (UnidentifiedImageError, OSError, SyntaxError) as exc:
        raise MomaError(
            f"topic {topic!r}: cannot decode compressed image (format {fmt!r}): {exc}"
        ) from None


def depth_metres(msg: Any, msgtype: str, topic: str) -> np.ndarray:
    """(H, W) float32 metres from a depth message; 0 and NaN are invalid."""
    if msgtype == COMPRESSED:
        img = _compressed_array(msg, topic)
        if img.dtype not in (np.uint16, np.int32) or img.ndim != 2:
            raise MomaError(f"topic {topic!r}: a compressed depth image must be a 16-bit PNG")
        return img.astype(np.float32) / 1000.0
    if msg.encoding not in DEPTH_ENCODINGS:
        raise MomaError(
            f"depth topic {topic!r} has encoding {msg.encoding!r}; expected 16UC1 "
            "(millimetres, 0 = invalid) or 32FC1 (metres, NaN = invalid)"
        )
    img = image_array(msg, topic)
    return img.astype(np.float32) / (1000.0 if img.dtype == np.uint16 else 1.0)


def colour_rgb(msg: Any, msgtype: str, topic: str) -> np.ndarray:
    """(H, W, 3) uint8 RGB from a colour message (rgb8, bgr8, rgba8, bgra8, mono8, JPEG,
    PNG)."""
    if msgtype == COMPRESSED:
        img = _compressed_array(msg, topic)
        if img.dtype != np.uint8:
            raise MomaError(f"topic {topic!r}: compressed colour image is not 8-bit")
        return np.ascontiguousarray(np.stack([img] * 3, -1) if img.ndim == 2 else img[..., :3])
    if msg.encoding not in RGB_ENCODINGS:
        raise MomaError(
            f"colour topic {topic!r} has encoding {msg.encoding!r}; expected one of "
            f"{', '.join(RGB_ENCODINGS)} or a CompressedImage"
        )
    img = image_array(msg, topic)
    if img.ndim == 2:
        return np.ascontiguousarray(np.stack([img] * 3, -1))
    if msg.encoding.startswith("bgr"):
        img = img[..., 2::-1]
    return np.ascontiguousarray(img[..., :3])


def mask_image(msg: Any, msgtype: str, topic: str) -> np.ndarray:
    """(H, W) bool from a mask message (mono8 / 8UC1 / mono16 / 16UC1 or a PNG; non-zero =
    inside)."""
    if msgtype == COMPRESSED:
        img = _compressed_array(msg, topic)
    elif msg.encoding not in MASK_ENCODINGS:
        raise MomaError(
            f"mask topic {topic!r} has encoding {msg.encoding!r}; expected one of "
            f"{', '.join(MASK_ENCODINGS)}"
        )
    else:
        img = image_array(msg, topic)
    return (img.max(-1) if img.ndim == 3 else img) != 0


# ---------------------------------------------------------------------------- TF
def transform_matrix(
    translation: Sequence[float] | np.ndarray, quaternion_xyzw: Sequence[float] | np.ndarray
) -> np.ndarray:
    """(4, 4) from a translation and an ``x, y, z, w`` quaternion (normalised here)."""
    from scipy.spatial.transform import Rotation

    q = np.asarray(quaternion_xyzw, np.float64)
    if not (np.isfinite(q).all() and np.linalg.norm(q) > 1e-9):
        raise MomaError(f"TF rotation {q.tolist()} is not a quaternion")
    m = np.eye(4)
    m[:3, :3] = Rotation.from_quat(q / np.linalg.norm(q)).as_matrix()
    m[:3, 3] = translation
    return m


class TransformBuffer:
    """The TF tree of a bag: static edges and time series of dynamic ones.

    An edge ``parent -> child`` holds ``T_parent_child`` (child coordinates to parent
    coordinates), as ``geometry_msgs/TransformStamped`` does. :meth:`lookup` composes the
    edges of the path between two frames at one time, interpolating dynamic edges (linear
    translation, spherical rotation) as tf2 does.
    """

    def __init__(self) -> None:
        self.static: dict[tuple[str, str], np.ndarray] = {}
        self._dynamic: dict[tuple[str, str], list[tuple[int, np.ndarray, np.ndarray]]] = (
            defaultdict(list)
        )
        self._sorted = True

    def add(self, parent: str, child: str, stamp_ns: int, transform: Any, static: bool) -> None:
        """Add a ``geometry_msgs/Transform`` message's edge."""
        t, r = transform.translation, transform.rotation
        parent, child = parent.lstrip("/"), child.lstrip("/")
        if static:
            self.static[(parent, child)] = transform_matrix((t.x, t.y, t.z), (r.x, r.y, r.z, r.w))
        else:
            q = np.array([r.x, r.y, r.z, r.w], np.float64)
            self._dynamic[(parent, child)].append((stamp_ns, np.array([t.x, t.y, t.z]), q))
            self._sorted = False

    def frames(self) -> list[str]:
        return sorted({f for edge in [*self.static, *self._dynamic] for f in edge})

    def _neighbours(self) -> dict[str, list[tuple[str, tuple[str, str], bool]]]:
        graph: dict[str, list[tuple[str, tuple[str, str], bool]]] = defaultdict(list)
        for edge in [*self.static, *self._dynamic]:
            graph[edge[0]].append((edge[1], edge, True))  # parent -> child: T as stored
            graph[edge[1]].append((edge[0], edge, False))  # child -> parent: inverted
        return graph

    def _edge(self, edge: tuple[str, str], stamp_ns: int) -> np.ndarray:
        if edge not in self._dynamic:
            return self.static[edge]
        from scipy.spatial.transform import Rotation, Slerp

        if not self._sorted:
            for samples in self._dynamic.values():
                samples.sort(key=lambda s: s[0])
            self._sorted = True
        samples = self._dynamic[edge]
        stamps = np.array([s[0] for s in samples], np.int64)
        tol = int(TF_EDGE_TOLERANCE * 1e9)
        if stamp_ns < stamps[0] - tol or stamp_ns > stamps[-1] + tol:
            raise MomaError(
                f"no /tf transform {edge[0]!r} -> {edge[1]!r} at t={stamp_ns * 1e-9:.3f} s: "
                f"the bag has it from {stamps[0] * 1e-9:.3f} to {stamps[-1] * 1e-9:.3f} s"
            )
        i = int(np.searchsorted(stamps, stamp_ns))
        if i == 0 or i == len(stamps):
            _, trans, quat = samples[0 if i == 0 else -1]
            return transform_matrix(trans, quat)
        (t0, p0, q0), (t1, p1, q1) = samples[i - 1], samples[i]
        a = (stamp_ns - t0) / (t1 - t0) if t1 > t0 else 0.0
        for q in (q0, q1):
            if not (np.isfinite(q).all() and np.linalg.norm(q) > 1e-9):
                raise MomaError(f"TF rotation {q.tolist()} of {edge[0]!r} -> {edge[1]!r}")
        rot = Slerp([0.0, 1.0], Rotation.from_quat([q0, q1]))([a])
        m = np.eye(4)
        m[:3, :3] = rot.as_matrix()[0]
        m[:3, 3] = (1 - a) * p0 + a * p1
        return m

    def lookup(self, target: str, source: str, stamp_ns: int) -> np.ndarray:
        """(4, 4) ``T_target_source``: ``source`` coordinates to ``target`` coordinates."""
        target, source = target.lstrip("/"), source.lstrip("/")
        if target == source:
            return np.eye(4)
        graph = self._neighbours()
        previous: dict[str, tuple[str, tuple[str, str], bool]] = {}
        queue, seen = deque([source]), {source}
        while queue and target not in seen:
            frame = queue.popleft()
            for nxt, edge, forward in graph.get(frame, []):
                if nxt not in seen:
                    seen.add(nxt)
                    previous[nxt] = (frame, edge, forward)
                    queue.append(nxt)
        if target not in seen:
            known = self.frames()
            raise MomaError(
                f"no TF path from the camera frame {source!r} to {target!r}; the bag's TF "
                f"frames are {known or 'none'}"
                + (
                    f" (connected to {source!r}: {sorted(seen - {source})})"
                    if len(seen) > 1
                    else ""
                )
            )
        # Walk back from the target: T_target_source = T_target_a @ T_a_b @ ... @ T_z_source.
        m, frame = np.eye(4), target
        while frame != source:
            prev, edge, forward = previous[frame]
            t = self._edge(edge, stamp_ns)  # T_parent_child
            # forward: prev is the parent, frame the child; we need T_frame_prev.
            m = m @ (np.linalg.inv(t) if forward else t)
            frame = prev
        return m


# ---------------------------------------------------------------------------- the bag
def _header_stamp_ns(raw: bytes | memoryview, topic: str) -> int:
    """``header.stamp`` from a serialised (CDR) stamped message without decoding the rest:
    every stamped message starts with it, after the 4-byte encapsulation header."""
    raw = bytes(raw[:12])
    if len(raw) < 12 or raw[1] not in (0, 1):
        raise MomaError(f"topic {topic!r}: a message is not CDR-encoded ROS 2 data")
    sec, nanosec = struct.unpack("<iI" if raw[1] == 1 else ">iI", raw[4:12])
    return sec * 1_000_000_000 + nanosec


class _Stream:
    """A topic's messages: bag times, header stamps and (for the selected ones) payloads."""

    def __init__(self, topic: str, msgtype: str) -> None:
        self.topic, self.msgtype = topic, msgtype
        self.log_ns: list[int] = []
        self.stamp_ns: list[int] = []

    def nearest(self, stamp_ns: int) -> int:
        stamps = np.asarray(self.stamp_ns, np.int64)
        return int(np.argmin(np.abs(stamps - stamp_ns)))


def _open_error(path: Path, exc: Exception) -> MomaError:
    text = " ".join(str(exc).split()) or type(exc).__name__
    return MomaError(f"bag {str(path)!r} is unreadable (truncated or damaged?): {text}")


def check_bag_path(path: str | Path) -> Path:
    """``path`` if it can be a ROS 2 bag (a directory, or a ``.mcap`` / ``.db3`` file)."""
    p = Path(path)
    if not p.exists():
        raise MomaError(f"bag {str(p)!r} does not exist")
    if p.is_file() and p.suffix.lower() == ".db3":
        raise MomaError(
            f"bag {str(p)!r}: give the bag directory (with metadata.yaml), not the .db3"
        )
    if p.is_file() and p.suffix.lower() != ".mcap":
        raise MomaError(f"bag {str(p)!r} is neither a ROS 2 bag directory nor a .mcap file")
    return p


def read_bag_frames(
    path: str | Path,
    topics: BagTopics,
    *,
    time: float | None = None,
    every: int | None = None,
) -> list[BagFrame]:
    """The selected depth frames of the bag at ``path``, decoded, paired and with their
    camera-to-base transforms.

    Args:
        path: a bag directory (``.db3`` or ``.mcap`` storage) or a single ``.mcap`` file.
        topics: the topics and frames to use.
        time: the depth frame recorded nearest this many seconds after the bag's start
            (as ``ros2 bag play --start-offset``).
        every: every ``every``-th depth frame, from the first. Exactly one of ``time`` and
            ``every`` is given.
    """
    if (time is None) == (every is None):
        raise MomaError("choose the frames with either a time or every N frames")
    if every is not None and every < 1:
        raise MomaError(f"every must be >= 1, got {every}")
    if time is not None and not (np.isfinite(time) and time >= 0):
        raise MomaError(f"time must be a number of seconds >= 0, got {time}")
    bag = check_bag_path(path)
    store = typestore()
    from rosbags.rosbag2 import Reader

    try:
        reader = Reader(bag)
        reader.open()
    except Exception as exc:  # the library raises its own, sqlite's and yaml's errors
        raise _open_error(bag, exc) from None
    try:
        return _read(reader, bag, store, topics, time, every)
    finally:
        reader.close()


def _read(
    reader: Any, bag: Path, store: Any, topics: BagTopics, time: float | None, every: int | None
) -> list[BagFrame]:
    available = {c.topic: c.msgtype for c in reader.connections}
    wanted = {"depth": topics.depth, "camera info": topics.camera_info, **topics.image_topics()}
    listing = ", ".join(f"{t} ({m})" for t, m in sorted(available.items())) or "none"
    expected = {"camera info": (CAMERA_INFO,)}
    for role, topic in wanted.items():
        if topic not in available:
            raise MomaError(f"{role} topic {topic!r} is not in the bag; its topics: {listing}")
        types = expected.get(role, (IMAGE, COMPRESSED))
        if available[topic] not in types:
            raise MomaError(
                f"{role} topic {topic!r} has type {available[topic]}, expected {' or '.join(types)}"
            )
    tf_topics = [t for t in TF_TOPICS if t in available]
    for t in tf_topics:
        if available[t] != TF_MESSAGE:
            raise MomaError(f"topic {t!r} has type {available[t]}, expected {TF_MESSAGE}")

    # Pass 1: stamps of the image streams (headers only), camera info and TF in full.
    streams = {topic: _Stream(topic, available[topic]) for topic in set(wanted.values())}
    infos: list[tuple[int, Any]] = []
    tf = TransformBuffer()
    conns = [c for c in reader.connections if c.topic in streams or c.topic in tf_topics]
    try:
        for conn, log_ns, raw in reader.messages(connections=conns):
            if conn.topic in tf_topics:
                msg = store.deserialize_cdr(raw, TF_MESSAGE)
                for ts in msg.transforms:
                    tf.add(
                        ts.header.frame_id,
                        ts.child_frame_id,
                        _stamp_ns(ts.header.stamp),
                        ts.transform,
                        static=conn.topic == "/tf_static",
                    )
            if conn.topic == topics.camera_info:
                info = store.deserialize_cdr(raw, CAMERA_INFO)
                infos.append((_stamp_ns(info.header.stamp), info))
            if conn.topic in streams and conn.topic != topics.camera_info:
                stream = streams[conn.topic]
                stream.log_ns.append(log_ns)
                stream.stamp_ns.append(_header_stamp_ns(raw, conn.topic))
    except MomaError:
        raise
    except Exception as exc:
        raise _open_error(bag, exc) from None

    depth = streams[topics.depth]
    if not depth.stamp_ns:
        raise MomaError(f"depth topic {topics.depth!r} has no message in the bag")
    if not infos:
        raise MomaError(f"camera info topic {topics.camera_info!r} has no message in the bag")
    for role, topic in topics.image_topics().items():
        if not streams[topic].stamp_ns:
            raise MomaError(f"{role} topic {topic!r} has no message in the bag")
    if time is not None:
        start = int(reader.start_time)
        offsets = (np.asarray(depth.log_ns, np.int64) - start) * 1e-9
        duration = (int(reader.end_time) - start) * 1e-9
        if time > duration + 1.0:
            raise MomaError(f"time {time:g} s is past the end of the bag ({duration:.3f} s long)")
        selected = [int(np.argmin(np.abs(offsets - time)))]
    else:
        assert every is not None
        selected = list(range(0, len(depth.stamp_ns), every))

    # Pair every selected frame before decoding anything: a gap is an error up front.
    pairs: dict[int, dict[str, int]] = {}
    for index in selected:
        stamp = depth.stamp_ns[index]
        pairs[index] = {}
        for role, topic in topics.image_topics().items():
            j = streams[topic].nearest(stamp)
            dt = (streams[topic].stamp_ns[j] - stamp) * 1e-9
            if abs(dt) > topics.max_dt:
                raise MomaError(
                    f"no {role} message on {topic!r} within {topics.max_dt:g} s of the depth "
                    f"frame {index} at t={stamp * 1e-9:.3f} s (the nearest is {abs(dt):.3f} s "
                    "away); raise --max-dt or record the topics together"
                )
            pairs[index][role] = j

    # Pass 2: decode the selected messages.
    need: dict[str, set[int]] = defaultdict(set)
    for index, roles in pairs.items():
        need[topics.depth].add(index)
        for role, j in roles.items():
            need[wanted[role]].add(j)
    raw_of: dict[tuple[str, int], Any] = {}
    counters: dict[str, int] = defaultdict(int)
    img_conns = [c for c in reader.connections if c.topic in need]
    try:
        for conn, _, raw in reader.messages(connections=img_conns):
            k = counters[conn.topic]
            counters[conn.topic] += 1
            if k in need[conn.topic]:
                raw_of[(conn.topic, k)] = store.deserialize_cdr(raw, conn.msgtype)
    except Exception as exc:
        raise _open_error(bag, exc) from None

    frames = []
    info_stamps = np.asarray([s for s, _ in infos], np.int64)
    for index, roles in pairs.items():
        msg = raw_of[(topics.depth, index)]
        d = depth_metres(msg, depth.msgtype, topics.depth)
        stamp = depth.stamp_ns[index]
        info = infos[int(np.argmin(np.abs(info_stamps - stamp)))][1]
        h, w = d.shape
        if (int(info.height), int(info.width)) not in ((h, w), (0, 0)):
            raise MomaError(
                f"camera info on {topics.camera_info!r} is for {info.width}x{info.height} "
                f"images but the depth image is {w}x{h}"
            )
        kmat = np.asarray(info.k, np.float64)
        intrinsics = (float(kmat[0]), float(kmat[4]), float(kmat[2]), float(kmat[5]))
        if not (kmat[0] > 0 and kmat[4] > 0):
            raise MomaError(
                f"camera info on {topics.camera_info!r} has no focal length (K={kmat.tolist()})"
            )
        camera = (msg.header.frame_id or info.header.frame_id).lstrip("/")
        if not camera:
            raise MomaError(f"depth topic {topics.depth!r}: the image has no header.frame_id")
        frame = BagFrame(
            index=index,
            stamp_ns=stamp,
            camera_frame=camera,
            base_frame=topics.base_frame,
            depth=d,
            intrinsics=intrinsics,
            camera_to_base=tf.lookup(topics.base_frame, camera, stamp),
        )
        for role, j in roles.items():
            topic = wanted[role]
            m = raw_of[(topic, j)]
            frame.paired_ns[role] = streams[topic].stamp_ns[j]
            if role == "rgb":
                frame.rgb = colour_rgb(m, streams[topic].msgtype, topic)
            elif role == "target mask":
                frame.target_mask = mask_image(m, streams[topic].msgtype, topic)
            else:
                frame.obstacle_masks.append(mask_image(m, streams[topic].msgtype, topic))
        frames.append(frame)
    return frames


# ---------------------------------------------------------------------------- predict
def predict_bag(
    path: str | Path,
    topics: BagTopics,
    robot: Any = "panda",
    *,
    time: float | None = None,
    every: int | None = None,
    target_mask: Any = None,
    checkpoint: Any = None,
    **predict_options: Any,
) -> list[tuple[BagFrame, Any]]:
    """:func:`momakitchen.predict` on the selected depth frames of a bag.

    The target mask comes from ``topics.target_mask`` (a segmenter's image topic, paired
    by time) or ``target_mask`` (one (H, W) mask or mask file for every frame), not both.
    ``checkpoint`` is loaded once for all frames; ``predict_options`` (``top_k``,
    ``mc_samples``, ...) go to :func:`momakitchen.predict` unchanged. Returns
    ``(frame, prediction)`` pairs in the bag's order.
    """
    from momakitchen.deploy.predict import load_mask, predict
    from momakitchen.train.checkpoint import LoadedRun, default_checkpoint, load_checkpoint

    if (topics.target_mask is None) == (target_mask is None):
        raise MomaError("give the target mask either as a mask topic or as a mask, not both")
    mask = load_mask(target_mask, "target mask") if target_mask is not None else None
    frames = read_bag_frames(path, topics, time=time, every=every)
    run = (
        checkpoint
        if isinstance(checkpoint, LoadedRun)
        else load_checkpoint(Path(checkpoint) if checkpoint is not None else default_checkpoint())
    )
    out = []
    for f in frames:
        target = f.target_mask if f.target_mask is not None else mask
        assert target is not None  # one of the two, checked above
        try:
            pred = predict(
                f.depth,
                f.intrinsics,
                f.camera_to_base,
                target,
                robot,
                rgb=f.rgb,
                obstacle_masks=f.obstacle_masks,
                checkpoint=run,
                **predict_options,
            )
        except MomaError as exc:
            raise MomaError(f"depth frame {f.index} at t={f.stamp:.3f} s: {exc}") from None
        out.append((f, pred))
    return out
