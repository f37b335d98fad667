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

Poses lie on the floor (z = 0) with the yaw as a rotation about z. Writing needs the
``robot`` extra (``rosbags``).
"""

from __future__ import annotations

import json
import os
import shutil
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from momakitchen.deploy.rosbag import typestore
from momakitchen.errors import MomaError
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


def topics(prefix: str = "/momakitchen") -> dict[str, str]:
    """Topic -> message type of the bag :func:`write_prediction_bag` writes."""
    return {
        f"{prefix}/goal": POSE_STAMPED,
        f"{prefix}/poses": POSE_ARRAY,
        f"{prefix}/affordance": POINT_CLOUD2,
        f"{prefix}/markers": MARKER_ARRAY,
        f"{prefix}/prediction": STRING,
    }


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

    def frame(self, sp: StampedPrediction) -> dict[str, Any]:
        """Message type -> message for one prediction."""
        t, p = self.t, sp.prediction
        header = self.header(sp.stamp_ns, sp.frame_id)
        poses = [self.pose(x, y, 0.0, yaw) for x, y, yaw in p.poses]
        cloud = np.column_stack([p.floor_xyz, p.affordance, p.uncertainty]).astype("<f4")
        fields = [
            t["sensor_msgs/msg/PointField"](name=name, offset=4 * i, datatype=7, count=1)
            for i, name in enumerate(CLOUD_FIELDS)
        ]
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
            POSE_STAMPED: t[POSE_STAMPED](header=header, pose=poses[0]),
            POSE_ARRAY: t[POSE_ARRAY](header=header, poses=poses),
            POINT_CLOUD2: t[POINT_CLOUD2](
                header=header,
                height=1,
                width=len(cloud),
                fields=fields,
                is_bigendian=False,
                point_step=4 * len(CLOUD_FIELDS),
                row_step=4 * len(CLOUD_FIELDS) * len(cloud),
                data=np.frombuffer(cloud.tobytes(), np.uint8),
                is_dense=True,
            ),
            MARKER_ARRAY: t[MARKER_ARRAY](markers=markers),
            STRING: t[STRING](data=json.dumps(p.to_dict(floor_points=False))),
        }


class PredictionBagWriter:
    """Writes predictions, one frame at a time, into a new ROS 2 bag directory at ``path``
    (MCAP storage; the directory must not exist). A context manager: the bag is complete
    when it closes."""

    def __init__(self, path: str | os.PathLike, prefix: str = "/momakitchen") -> None:
        if not prefix.startswith("/") or prefix.endswith("/"):
            raise MomaError(
                f"topic prefix must start with '/' and not end with one, got {prefix!r}"
            )
        self.path, self.prefix = Path(path), prefix
        self.store = typestore()
        self.count = 0

    def __enter__(self) -> PredictionBagWriter:
        from rosbags.rosbag2 import StoragePlugin, Writer

        self._build = _Messages(self.store)
        self._writer = Writer(self.path, version=9, storage_plugin=StoragePlugin.MCAP)
        self._writer.open()
        self._conns = {
            msgtype: self._writer.add_connection(topic, msgtype, typestore=self.store)
            for topic, msgtype in topics(self.prefix).items()
        }
        return self

    def write(self, sp: StampedPrediction) -> None:
        for msgtype, msg in self._build.frame(sp).items():
            data = self.store.serialize_cdr(msg, msgtype)
            self._writer.write(self._conns[msgtype], sp.stamp_ns, data)
        self.count += 1

    def __exit__(self, *exc: object) -> None:
        self._writer.close()


def write_prediction_bag(
    path: str | os.PathLike,
    predictions: Sequence[StampedPrediction],
    prefix: str = "/momakitchen",
) -> Path:
    """Write ``predictions`` as a ROS 2 bag directory (MCAP storage) at ``path``.

    The bag is written beside ``path`` and renamed onto it when complete, so a failure
    leaves no partial bag; an existing bag at ``path`` is replaced.
    """
    if not predictions:
        raise MomaError("no prediction to write")
    out = Path(path)
    tmp = out.with_name(f".{out.name}.{os.getpid()}.tmp")
    shutil.rmtree(tmp, ignore_errors=True)
    try:
        # rosbags names the storage file after the directory: give it the final name.
        tmp.mkdir(parents=True)
        inner = tmp / out.name
        with PredictionBagWriter(inner, prefix) as writer:
            for sp in sorted(predictions, key=lambda s: s.stamp_ns):
                writer.write(sp)
        if out.is_dir():
            shutil.rmtree(out)
        os.replace(inner, out)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return out
