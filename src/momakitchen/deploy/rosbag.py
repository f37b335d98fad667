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
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from momakitchen.errors import MomaError

if TYPE_CHECKING:
    from momakitchen.models.inference import Prediction

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
    except (UnidentifiedImageError, Image.DecompressionBombError, OSError, SyntaxError) as exc:
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
        self._stamps: dict[tuple[str, str], np.ndarray] = {}
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
            for key, samples in self._dynamic.items():
                samples.sort(key=lambda s: s[0])
                self._stamps[key] = np.array([s[0] for s in samples], np.int64)
            self._sorted = True
        samples, stamps = self._dynamic[edge], self._stamps[edge]
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
class _Stream:
    """A topic's messages: bag times, header stamps and (for the selected ones) payloads."""

    def __init__(self, topic: str, msgtype: str) -> None:
        self.topic, self.msgtype = topic, msgtype
        self.log_ns: list[int] = []
        self.stamp_ns: list[int] = []
        self._order: np.ndarray | None = None  # by stamp, made on the first nearest()
        self._sorted = np.zeros(0, np.int64)

    def nearest(self, stamp_ns: int) -> int:
        """Index of the message whose header stamp is nearest ``stamp_ns``."""
        if self._order is None:
            stamps = np.asarray(self.stamp_ns, np.int64)
            self._order = np.argsort(stamps, kind="stable")
            self._sorted = stamps[self._order]
        i = int(np.searchsorted(self._sorted, stamp_ns))
        near = [c for c in (i - 1, i) if 0 <= c < len(self._sorted)]
        best = min(near, key=lambda c: abs(int(self._sorted[c]) - stamp_ns))
        return int(self._order[best])


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
    if p.is_dir() and not (p / "metadata.yaml").is_file():
        raise MomaError(
            f"bag directory {str(p)!r} has no metadata.yaml: not a ROS 2 bag (give a lone "
            ".mcap file itself, or rebuild the metadata with `ros2 bag reindex`)"
        )
    return p


def _header(raw: bytes | memoryview, topic: str) -> tuple[int, str]:
    """``header.stamp`` (ns) and ``header.frame_id`` from a serialised (CDR) stamped
    message without decoding the rest: every stamped message starts with its header, after
    the 4-byte encapsulation header."""
    head = bytes(raw[:16])
    if len(head) < 16 or head[1] not in (0, 1):
        raise MomaError(f"topic {topic!r}: a message is not CDR-encoded ROS 2 data")
    order = "<" if head[1] == 1 else ">"
    sec, nanosec, length = struct.unpack(order + "iII", head[4:16])
    frame_id = bytes(raw[16 : 16 + max(length - 1, 0)]).decode("utf-8", errors="replace")
    return sec * 1_000_000_000 + nanosec, frame_id


@dataclass
class _Planned:
    """A selected depth frame, paired and placed before any image is decoded."""

    index: int
    stamp_ns: int
    camera: str
    intrinsics: tuple[float, float, float, float]
    camera_to_base: np.ndarray
    pairs: dict[str, int]  # role -> message index on its topic


class BagFrames:
    """The selected depth frames of a bag, checked on opening and decoded one by one.

    Opening reads the bag once without decoding images: it checks the topics and their
    types, the first message of every image topic (its encoding), the pairing of every
    selected frame within ``topics.max_dt``, the camera info and the TF path at every
    selected frame's stamp, so any error is raised here, before the model runs.
    Iterating reads the bag again and yields each frame as soon as its messages have been
    seen, so memory stays bounded however many frames are selected. Use as a context
    manager (or call :meth:`close`).

    Args:
        path: a bag directory (``.db3`` or ``.mcap`` storage) or a single ``.mcap`` file.
        topics: the topics and frames to use.
        time: the depth frame recorded nearest this many seconds after the bag's start
            (as ``ros2 bag play --start-offset``).
        every: every ``every``-th depth frame, from the first. Exactly one of ``time`` and
            ``every`` is given.
    """

    def __init__(
        self,
        path: str | Path,
        topics: BagTopics,
        *,
        time: float | None = None,
        every: int | None = None,
    ) -> None:
        if (time is None) == (every is None):
            raise MomaError("choose the frames with either a time or every N frames")
        if every is not None and every < 1:
            raise MomaError(f"every must be >= 1, got {every}")
        if time is not None and not (np.isfinite(time) and time >= 0):
            raise MomaError(f"time must be a number of seconds >= 0, got {time}")
        self.path = check_bag_path(path)
        self.topics = topics
        self.store = typestore()
        from rosbags.rosbag2 import Reader

        try:
            self.reader = Reader(self.path)
            self.reader.open()
        except Exception as exc:  # the library raises its own, sqlite's and yaml's errors
            raise _open_error(self.path, exc) from None
        try:
            self.planned = self._plan(time, every)
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
                raise _open_error(self.path, exc) from None
            yield item

    def _decode(self, role: str, topic: str, msgtype: str, raw: Any) -> np.ndarray:
        try:
            msg = self.store.deserialize_cdr(raw, msgtype)
        except Exception as exc:
            raise _open_error(self.path, exc) from None
        if role == "depth":
            return depth_metres(msg, msgtype, topic)
        if role == "rgb":
            return colour_rgb(msg, msgtype, topic)
        return mask_image(msg, msgtype, topic)

    def _plan(self, time: float | None, every: int | None) -> list[_Planned]:
        topics, store = self.topics, self.store
        available = {c.topic: c.msgtype for c in self.reader.connections}
        images = {"depth": topics.depth, **topics.image_topics()}
        wanted = {**images, "camera info": topics.camera_info}
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
        tf_topics = [t for t in TF_TOPICS if t in available]
        for t in tf_topics:
            if available[t] != TF_MESSAGE:
                raise MomaError(f"topic {t!r} has type {available[t]}, expected {TF_MESSAGE}")

        # One pass: image headers only (and each image topic's first message, decoded to
        # check its encoding), camera info and TF in full.
        self.streams = streams = {t: _Stream(t, available[t]) for t in images.values()}
        frame_ids: list[str] = []
        first: dict[str, Any] = {}
        infos: list[tuple[int, Any]] = []
        tf = TransformBuffer()
        for conn, log_ns, raw in self._messages({*streams, topics.camera_info, *tf_topics}):
            if conn.topic in tf_topics:
                try:
                    msg = store.deserialize_cdr(raw, TF_MESSAGE)
                except Exception as exc:
                    raise _open_error(self.path, exc) from None
                for ts in msg.transforms:
                    tf.add(
                        ts.header.frame_id,
                        ts.child_frame_id,
                        _stamp_ns(ts.header.stamp),
                        ts.transform,
                        static=conn.topic == "/tf_static",
                    )
            if conn.topic == topics.camera_info:
                try:
                    info = store.deserialize_cdr(raw, CAMERA_INFO)
                except Exception as exc:
                    raise _open_error(self.path, exc) from None
                infos.append((_stamp_ns(info.header.stamp), info))
            if conn.topic in streams:
                stream = streams[conn.topic]
                stamp, frame_id = _header(raw, conn.topic)
                stream.log_ns.append(log_ns)
                stream.stamp_ns.append(stamp)
                if conn.topic == topics.depth:
                    frame_ids.append(frame_id)
                first.setdefault(conn.topic, raw)

        for role, topic in images.items():
            if not streams[topic].stamp_ns:
                raise MomaError(f"{role} topic {topic!r} has no message in the bag")
        if not infos:
            raise MomaError(f"camera info topic {topics.camera_info!r} has no message in the bag")
        shapes = {
            role: self._decode(role, topic, streams[topic].msgtype, first[topic]).shape[:2]
            for role, topic in images.items()
        }
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

        h, w = shapes["depth"]
        info_stamps = np.asarray([s for s, _ in infos], np.int64)
        planned = []
        for index in selected:
            stamp = depth.stamp_ns[index]
            pairs = {}
            for role, topic in topics.image_topics().items():
                j = streams[topic].nearest(stamp)
                dt = (streams[topic].stamp_ns[j] - stamp) * 1e-9
                if abs(dt) > topics.max_dt:
                    raise MomaError(
                        f"no {role} message on {topic!r} within {topics.max_dt:g} s of the "
                        f"depth frame {index} at t={stamp * 1e-9:.3f} s (the nearest is "
                        f"{abs(dt):.3f} s away); raise --max-dt or record the topics together"
                    )
                pairs[role] = j
            info = infos[int(np.argmin(np.abs(info_stamps - stamp)))][1]
            if (int(info.height), int(info.width)) not in ((h, w), (0, 0)):
                raise MomaError(
                    f"camera info on {topics.camera_info!r} is for {info.width}x{info.height} "
                    f"images but the depth image is {w}x{h}"
                )
            k = np.asarray(info.k, np.float64)
            if not (k.shape == (9,) and k[0] > 0 and k[4] > 0):
                raise MomaError(
                    f"camera info on {topics.camera_info!r} has no focal length (K={k.tolist()})"
                )
            camera = (frame_ids[index] or info.header.frame_id).lstrip("/")
            if not camera:
                raise MomaError(f"depth topic {topics.depth!r}: the image has no header.frame_id")
            planned.append(
                _Planned(
                    index=index,
                    stamp_ns=stamp,
                    camera=camera,
                    intrinsics=(float(k[0]), float(k[4]), float(k[2]), float(k[5])),
                    camera_to_base=tf.lookup(topics.base_frame, camera, stamp),
                    pairs=pairs,
                )
            )
        return planned

    def __iter__(self) -> Iterator[BagFrame]:
        """The planned frames, each yielded once all its messages have been read."""
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
                    decoded[kind] = self._decode(role, conn.topic, conn.msgtype, raw)
                parts[plan.index][role] = decoded[kind]
                if len(parts[plan.index]) == len(plan.pairs) + 1:
                    yield self._frame(plan, parts.pop(plan.index))

    def _frame(self, plan: _Planned, parts: dict[str, np.ndarray]) -> BagFrame:
        depth = parts["depth"]
        for role, array in parts.items():
            if array.shape[:2] != depth.shape:
                raise MomaError(
                    f"depth frame {plan.index}: the {role} image is "
                    f"{array.shape[1]}x{array.shape[0]}, the depth image "
                    f"{depth.shape[1]}x{depth.shape[0]}"
                )
        return BagFrame(
            index=plan.index,
            stamp_ns=plan.stamp_ns,
            camera_frame=plan.camera,
            base_frame=self.topics.base_frame,
            depth=depth,
            intrinsics=plan.intrinsics,
            camera_to_base=plan.camera_to_base,
            rgb=parts.get("rgb"),
            target_mask=parts.get("target mask"),
            obstacle_masks=[
                parts[f"obstacle mask {i}"] for i in range(len(self.topics.obstacle_masks))
            ],
            paired_ns={
                role: self.streams[self.topics.image_topics()[role]].stamp_ns[j]
                for role, j in plan.pairs.items()
            },
        )


def read_bag_frames(
    path: str | Path,
    topics: BagTopics,
    *,
    time: float | None = None,
    every: int | None = None,
) -> list[BagFrame]:
    """All the selected frames of a bag at once (see :class:`BagFrames`, which yields
    them one by one)."""
    with BagFrames(path, topics, time=time, every=every) as frames:
        return list(frames)


# ---------------------------------------------------------------------------- predict
def predict_frames(
    frames: Iterable[BagFrame],
    robot: Any = "panda",
    *,
    target_mask: Any = None,
    checkpoint: Any = None,
    **predict_options: Any,
) -> Iterator[tuple[BagFrame, Prediction]]:
    """:func:`momakitchen.predict` on each frame, as the frames come.

    ``target_mask`` (one (H, W) mask or mask file) serves every frame that has no mask
    topic's; ``checkpoint`` and the mask are loaded here, once, before the first frame is
    read; ``predict_options`` (``top_k``, ``mc_samples``, ...) go to
    :func:`momakitchen.predict` unchanged.
    """
    from momakitchen.deploy.predict import load_mask, predict
    from momakitchen.train.checkpoint import LoadedRun, default_checkpoint, load_checkpoint

    mask = load_mask(target_mask, "target mask") if target_mask is not None else None
    run = (
        checkpoint
        if isinstance(checkpoint, LoadedRun)
        else load_checkpoint(Path(checkpoint) if checkpoint is not None else default_checkpoint())
    )

    def each() -> Iterator[tuple[BagFrame, Prediction]]:
        for f in frames:
            target = f.target_mask if f.target_mask is not None else mask
            if target is None:
                raise MomaError(f"depth frame {f.index} has no target mask")
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
            yield f, pred

    return each()


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
) -> list[tuple[BagFrame, Prediction]]:
    """:func:`momakitchen.predict` on the selected depth frames of a bag: ``(frame,
    prediction)`` pairs in the bag's order.

    The target mask comes from ``topics.target_mask`` (a segmenter's image topic, paired
    by time) or ``target_mask`` (one (H, W) mask or mask file for every frame), not both.
    Other arguments as for :class:`BagFrames` and :func:`predict_frames`.
    """
    if (topics.target_mask is None) == (target_mask is None):
        raise MomaError("give the target mask either as a mask topic or as a mask, not both")
    with BagFrames(path, topics, time=time, every=every) as frames:
        preds = predict_frames(
            frames, robot, target_mask=target_mask, checkpoint=checkpoint, **predict_options
        )
        return sorted(preds, key=lambda fp: fp[0].index)
