"""Opening a recorded ROS 2 bag: its path, the message types, the ``rosbags`` type store,
and the header stamps of its messages read without decoding them.

Reading needs the ``robot`` extra (``rosbags``).
"""

from __future__ import annotations

import struct
from pathlib import Path
from typing import Any

import numpy as np

from momakitchen.errors import MomaError

TF_TOPICS = ("/tf_static", "/tf")
IMAGE = "sensor_msgs/msg/Image"
COMPRESSED = "sensor_msgs/msg/CompressedImage"
CAMERA_INFO = "sensor_msgs/msg/CameraInfo"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"


def typestore() -> Any:
    """The ROS 2 (Humble) message types of ``rosbags``; MomaError when it is missing."""
    try:
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise MomaError(
            "reading and writing ROS 2 bags needs the robot extra: pip install -e '.[robot]'"
        ) from None
    return get_typestore(Stores.ROS2_HUMBLE)


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


def open_error(path: Path, exc: Exception) -> MomaError:
    """The one-line error for a bag the library cannot read (it raises its own, sqlite's
    and yaml's errors, whose text may span lines)."""
    text = " ".join(str(exc).split()) or type(exc).__name__
    return MomaError(f"bag {str(path)!r} is unreadable (truncated or damaged?): {text}")


def stamp_ns(stamp: Any) -> int:
    """A ``builtin_interfaces/Time`` in nanoseconds."""
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def header_of(raw: bytes | memoryview, topic: str) -> tuple[int, str]:
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


class Stream:
    """A topic's messages: bag (log) times and header stamps, in the bag's order."""

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
