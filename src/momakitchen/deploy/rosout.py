"""Predictions as ROS 2 messages: a bag that ``ros2 bag play`` replays and RViz or Foxglove
shows.

:func:`write_prediction_bag` writes a ROS 2 bag directory with MCAP storage (its
``metadata.yaml`` and one ``.mcap`` file, which Foxglove also opens on its own). Per frame,
stamped with the frame's time and in its base frame:

========================  ===================================  =================================
topic                     type                                 content
========================  ===================================  =================================
``PREFIX/goal``           ``geometry_msgs/msg/PoseStamped``    the best base pose (Top-1), the
                                                               form a navigation goal takes
``PREFIX/poses``          ``geometry_msgs/msg/PoseArray``      the Top-k poses, best first
``PREFIX/affordance``     ``sensor_msgs/msg/PointCloud2``      every floor point: float32 x, y,
                                                               z, affordance, uncertainty
``PREFIX/markers``        ``visualization_msgs/msg/MarkerArray``  DELETEALL, then an arrow and a
                                                               label per pose and the target
``PREFIX/prediction``     ``std_msgs/msg/String``              ``prediction.json`` without the
                                                               floor points
========================  ===================================  =================================

With the frames' maps fused in the odometry frame (:class:`StampedFusion`), once, stamped
with the last fused frame's time and in the odometry frame:

============================  ===============================  =================================
``PREFIX/fused_goal``         ``geometry_msgs/msg/PoseStamped``  the fused goal, facing the target
``PREFIX/fused_affordance``   ``sensor_msgs/msg/PointCloud2``    the fused cells (z = 0): float32
                                                                 x, y, z, affordance, uncertainty
============================  ===============================  =================================

Poses lie on the floor (z = 0) with the yaw as a rotation about z. Writing needs the
``robot`` extra (``rosbags``).
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from momakitchen.deploy.bagread import typestore
from momakitchen.deploy.dirswap import stage_beside, swap_in
from momakitchen.errors import MomaError
from momakitchen.fileio import DISK_FULL, disk_full_message, dumps_strict
from momakitchen.models.inference import Prediction

POSE_STAMPED = "geometry_msgs/msg/PoseStamped"
POSE_ARRAY = "geometry_msgs/msg/PoseArray"
POINT_CLOUD2 = "sensor_msgs/msg/PointCloud2"
MARKER_ARRAY = "visualization_msgs/msg/MarkerArray"
STRING = "std_msgs/msg/String"
CLOUD_FIELDS = ("x", "y", "z", "affordance", "uncertainty")
# visualization_msgs/Marker constants (the message's own)
ARROW, SPHERE, TEXT = 0, 2, 9
ADD, DELETEALL = 0, 3


@dataclass(frozen=True)
class StampedPrediction:
    """A prediction with the time and base frame of the depth frame it came from."""

    stamp_ns: int
    frame_id: str
    prediction: Prediction


@dataclass(frozen=True)
class StampedFusion:
    """The fused map of several frames in the odometry frame ``frame_id``, stamped with the
    last fused frame's time. Shapes: ``cells`` (M, 2) xy; ``affordance``, ``uncertainty``
    (M,); ``goal`` (x, y, yaw) or None (no goal: only the map is written)."""

    stamp_ns: int
    frame_id: str
    cells: np.ndarray
    affordance: np.ndarray
    uncertainty: np.ndarray
    goal: tuple[float, float, float] | None


# Message type per topic name after the prefix.
FRAME_TOPICS = {
    "goal": POSE_STAMPED,
    "poses": POSE_ARRAY,
    "affordance": POINT_CLOUD2,
    "markers": MARKER_ARRAY,
    "prediction": STRING,
}
FUSED_TOPICS = {"fused_goal": POSE_STAMPED, "fused_affordance": POINT_CLOUD2}


def topics(prefix: str = "/momakitchen", fused: bool = False) -> dict[str, str]:
    """Topic -> message type of the bag :class:`PredictionBagWriter` writes (``fused``:
    with the topics of a :class:`StampedFusion`)."""
    names = {**FRAME_TOPICS, **(FUSED_TOPICS if fused else {})}
    return {f"{prefix}/{name}": msgtype for name, msgtype in names.items()}


def yaw_quaternion(yaw: float) -> tuple[float, float, float, float]:
    """``x, y, z, w`` of a rotation by ``yaw`` about z."""
    return 0.0, 0.0, float(np.sin(yaw / 2)), float(np.cos(yaw / 2))


class _Messages:
    """Builders of the messages from the ``rosbags`` types."""

    def __init__(self, store: Any) -> None:
        self.store, self.t = store, store.types

    def header(self, stamp_ns: int, frame_id: str) -> Any:
        stamp = self.t["builtin_interfaces/msg/Time"](
            sec=stamp_ns // 1_000_000_000, nanosec=stamp_ns % 1_000_000_000
        )
        return self.t["std_msgs/msg/Header"](stamp=stamp, frame_id=frame_id)

    def pose(self, x: float, y: float, z: float, yaw: float = 0.0) -> Any:
        qx, qy, qz, qw = yaw_quaternion(yaw)
        return self.t["geometry_msgs/msg/Pose"](
            position=self.t["geometry_msgs/msg/Point"](x=float(x), y=float(y), z=float(z)),
            orientation=self.t["geometry_msgs/msg/Quaternion"](x=qx, y=qy, z=qz, w=qw),
        )

    def marker(
        self,
        header: Any,
        ns: str,
        id_: int,
        kind: int,
        pose: Any,
        scale: tuple[float, float, float],
        rgba: tuple[float, float, float, float],
        text: str = "",
        action: int = ADD,
    ) -> Any:
        t = self.t
        return t["visualization_msgs/msg/Marker"](
            header=header,
            ns=ns,
            id=id_,
            type=kind,
            action=action,
            pose=pose,
            scale=t["geometry_msgs/msg/Vector3"](x=scale[0], y=scale[1], z=scale[2]),
            color=t["std_msgs/msg/ColorRGBA"](r=rgba[0], g=rgba[1], b=rgba[2], a=rgba[3]),
            lifetime=t["builtin_interfaces/msg/Duration"](sec=0, nanosec=0),
            frame_locked=False,
            points=[],
            colors=[],
            texture_resource="",
            texture=t["sensor_msgs/msg/CompressedImage"](
                header=t["std_msgs/msg/Header"](
                    stamp=t["builtin_interfaces/msg/Time"](sec=0, nanosec=0), frame_id=""
                ),
                format="",
                data=np.zeros(0, np.uint8),
            ),
            uv_coordinates=[],
            text=text,
            mesh_resource="",
            mesh_file=t["visualization_msgs/msg/MeshFile"](filename="", data=np.zeros(0, np.uint8)),
            mesh_use_embedded_materials=False,
        )

    def cloud(
        self, header: Any, xyz: np.ndarray, affordance: np.ndarray, uncertainty: np.ndarray
    ) -> Any:
        """A PointCloud2 of float32 ``x, y, z, affordance, uncertainty`` from (N, 3), (N,)
        and (N,) arrays."""
        t = self.t
        cloud = np.column_stack([xyz, affordance, uncertainty]).astype("<f4")
        fields = [
            t["sensor_msgs/msg/PointField"](name=name, offset=4 * i, datatype=7, count=1)
            for i, name in enumerate(CLOUD_FIELDS)
        ]
        return t[POINT_CLOUD2](
            header=header,
            height=1,
            width=len(cloud),
            fields=fields,
            is_bigendian=False,
            point_step=4 * len(CLOUD_FIELDS),
            row_step=4 * len(CLOUD_FIELDS) * len(cloud),
            data=np.frombuffer(cloud.tobytes(), np.uint8),
            is_dense=True,
        )

    def frame(self, sp: StampedPrediction) -> dict[str, Any]:
        """Topic name (after the prefix) -> message for one prediction."""
        t, p = self.t, sp.prediction
        header = self.header(sp.stamp_ns, sp.frame_id)
        poses = [self.pose(x, y, 0.0, yaw) for x, y, yaw in p.poses]
        markers = [
            self.marker(
                header, "", 0, ARROW, self.pose(0, 0, 0), (0, 0, 0), (0,) * 4, action=DELETEALL
            )
        ]
        k = len(poses)
        for rank, (pose, score) in enumerate(zip(poses, p.pose_scores, strict=True)):
            # Best in green, fading to yellow; each arrow 0.3 m long.
            shade = rank / max(k - 1, 1)
            markers.append(
                self.marker(
                    header, "poses", rank, ARROW, pose, (0.3, 0.05, 0.05), (shade, 1.0, 0.0, 1.0)
                )
            )
            x, y, _ = p.poses[rank]
            markers.append(
                self.marker(
                    header,
                    "scores",
                    rank,
                    TEXT,
                    self.pose(x, y, 0.25),
                    (0, 0, 0.08),
                    (1.0, 1.0, 1.0, 1.0),
                    text=f"{rank + 1}: {float(score):.2f}",
                )
            )
        markers.append(
            self.marker(
                header,
                "target",
                0,
                SPHERE,
                self.pose(*p.target_xyz),
                (0.1, 0.1, 0.1),
                (1.0, 0.0, 0.0, 1.0),
            )
        )
        return {
            "goal": t[POSE_STAMPED](header=header, pose=poses[0]),
            "poses": t[POSE_ARRAY](header=header, poses=poses),
            "affordance": self.cloud(header, p.floor_xyz, p.affordance, p.uncertainty),
            "markers": t[MARKER_ARRAY](markers=markers),
            "prediction": t[STRING](data=dumps_strict(p.to_dict(floor_points=False))),
        }

    def fused(self, sf: StampedFusion) -> dict[str, Any]:
        """Topic name (after the prefix) -> message for a fused map."""
        header = self.header(sf.stamp_ns, sf.frame_id)
        cells = np.asarray(sf.cells, np.float64).reshape(-1, 2)
        xyz = np.column_stack([cells, np.zeros(len(cells))])
        msgs = {"fused_affordance": self.cloud(header, xyz, sf.affordance, sf.uncertainty)}
        if sf.goal is not None:
            msgs["fused_goal"] = self.t[POSE_STAMPED](
                header=header, pose=self.pose(*sf.goal[:2], 0.0, sf.goal[2])
            )
        return msgs


class PredictionBagWriter:
    """Writes predictions, one frame at a time, into a new ROS 2 bag directory at ``path``
    (MCAP storage; the directory must not exist). A context manager: the bag is complete
    when it closes without an error (an error leaves an incomplete bag behind, for the
    caller to remove). ``fused``: the bag also gets the topics of :meth:`write_fused`. A
    full disk is a MomaError naming ``path``."""

    def __init__(
        self, path: str | os.PathLike, prefix: str = "/momakitchen", fused: bool = False
    ) -> None:
        if not prefix.startswith("/") or prefix.endswith("/"):
            raise MomaError(
                f"topic prefix must start with '/' and not end with one, got {prefix!r}"
            )
        self.path, self.prefix, self.fused = Path(path), prefix, fused
        self.store = typestore()
        self.count = 0

    @contextmanager
    def _writing(self) -> Iterator[None]:
        try:
            yield
        except OSError as exc:
            if exc.errno in DISK_FULL:
                raise MomaError(disk_full_message(self.path, exc)) from None
            raise

    def __enter__(self) -> PredictionBagWriter:
        from rosbags.rosbag2 import StoragePlugin, Writer

        self._build = _Messages(self.store)
        self._writer = Writer(self.path, version=9, storage_plugin=StoragePlugin.MCAP)
        with self._writing():
            self._writer.open()
            self._conns = {
                topic: self._writer.add_connection(topic, msgtype, typestore=self.store)
                for topic, msgtype in topics(self.prefix, self.fused).items()
            }
        return self

    def _write(self, stamp_ns: int, msgs: dict[str, Any]) -> None:
        with self._writing():
            for name, msg in msgs.items():
                conn = self._conns[f"{self.prefix}/{name}"]
                self._writer.write(conn, stamp_ns, self.store.serialize_cdr(msg, conn.msgtype))

    def write(self, sp: StampedPrediction) -> None:
        self._write(sp.stamp_ns, self._build.frame(sp))
        self.count += 1

    def write_fused(self, sf: StampedFusion) -> None:
        """The fused map and its goal (needs ``fused=True``)."""
        if not self.fused:
            raise MomaError("this bag was opened without the fused topics (fused=True)")
        self._write(sf.stamp_ns, self._build.fused(sf))

    def __exit__(self, exc_type: object, *exc: object) -> None:
        if exc_type is not None:
            self._writer.abort()  # no index or metadata for a bag that is not complete
            return
        with self._writing():
            self._writer.close()


def write_prediction_bag(
    path: str | os.PathLike,
    predictions: Sequence[StampedPrediction],
    prefix: str = "/momakitchen",
    fusion: StampedFusion | None = None,
) -> Path:
    """Write ``predictions`` (and a fused map) as a ROS 2 bag directory (MCAP storage) at
    ``path``.

    The bag is written beside ``path`` and swapped in when complete, so a failure leaves
    no partial bag and an existing bag at ``path`` as it was; an existing bag is replaced.
    """
    if not predictions:
        raise MomaError("no prediction to write")
    out = Path(path)
    stage = stage_beside(out)
    try:
        # rosbags names the storage file after the directory: give it the final name.
        inner = stage / out.name
        with PredictionBagWriter(inner, prefix, fused=fusion is not None) as writer:
            for sp in sorted(predictions, key=lambda s: s.stamp_ns):
                writer.write(sp)
            if fusion is not None:
                writer.write_fused(fusion)
        swap_in(inner, out)
    finally:
        shutil.rmtree(stage, ignore_errors=True)
    return out
