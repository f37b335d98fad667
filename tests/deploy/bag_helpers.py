"""ROS 2 bags written from simulated frames, as a robot records them: depth, colour,
segmenter masks, camera info and a TF tree (a static camera mount on a moving head, and a
moving odom -> base_link)."""

from __future__ import annotations

import io
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

T0 = 1_700_000_000 * 10**9  # the recording's clock (ns)


def frame_stamps(n: int) -> list[int]:
    """The stamps of a recording's ``n`` depth frames: one a second from T0 + 1 s."""
    return [T0 + (i + 1) * 1_000_000_000 for i in range(n)]


FRAME_NS = frame_stamps(2)  # the depth frames' stamps of a two-frame recording
RGB_DELAY_NS = 4_000_000  # colour (and the masks made from it) 4 ms after the depth
DEPTH = "/camera/aligned_depth_to_color/image_raw"
INFO = "/camera/color/camera_info"
RGB = "/camera/color/image_raw"
MASK = "/segmenter/target_mask"
OBSTACLES = "/segmenter/obstacle_mask"
CAMERA = "camera_color_optical_frame"
# predict --bag's options for the topics write_bag records
TOPICS = [
    "--depth-topic",
    DEPTH,
    "--camera-info-topic",
    INFO,
    "--rgb-topic",
    RGB,
    "--target-mask-topic",
    MASK,
    "--obstacle-mask-topic",
    OBSTACLES,
]
# camera_link -> optical frame (REP 103: optical z forward, x right, y down)
LINK_OPTICAL = np.array([[0, 0, 1, 0], [-1, 0, 0, 0], [0, -1, 0, 0], [0, 0, 0, 1]], float)
HEAD_LINK = np.eye(4)
HEAD_LINK[:3, :3] = Rotation.from_euler("xyz", [0.01, -0.02, 0.03]).as_matrix()
HEAD_LINK[:3, 3] = [0.06, 0.0, 0.09]  # head_link -> camera_link: the camera's mount


@dataclass
class Frame:
    """A frame to record. ``depth`` (H, W) metres; ``rgb`` (H, W, 3); masks (H, W) bool.

    ``extra`` may hold ``depth_encoding`` (this frame's, overriding the recording's) and
    ``no_head_tf`` (True: no /tf sample of the head near this frame)."""

    depth: np.ndarray
    rgb: np.ndarray
    target: np.ndarray
    obstacle: np.ndarray
    intrinsics: np.ndarray  # fx, fy, cx, cy
    camera_to_base: np.ndarray  # (4, 4)
    extra: dict = field(default_factory=dict)


def episode_frames(view_root: Path) -> list[Frame]:
    """The views of the first episode of a generated dataset's scene 3, as frames to record
    (the head tilts between them)."""
    from momakitchen.data.episode import SEMANTIC_CLASSES
    from momakitchen.data.shard import SceneShard

    target, obstacle = SEMANTIC_CLASSES.index("target"), SEMANTIC_CLASSES.index("obstacle")
    out = []
    with SceneShard(view_root / "scenes" / "scene_000003.h5") as shard:
        for i in shard.episode_indices(0):
            ep = shard.episode(0, i)
            out.append(
                Frame(
                    ep.depth,
                    ep.rgb,
                    ep.semantic == target,
                    ep.semantic == obstacle,
                    ep.intrinsics,
                    ep.camera_to_base,
                    {"robot": ep.robot},
                )
            )
    return out


def quarter(frames: list[Frame]) -> list[Frame]:
    """The frames at a quarter of their resolution: quick to record and predict on."""
    return [
        Frame(
            f.depth[::4, ::4],
            f.rgb[::4, ::4],
            f.target[::4, ::4],
            f.obstacle[::4, ::4],
            np.asarray(f.intrinsics) / 4,
            f.camera_to_base,
            dict(f.extra),
        )
        for f in frames
    ]


def changed(frame: Frame, **fields) -> Frame:
    """A copy of ``frame`` with some fields replaced (``extra`` merged)."""
    extra = {**frame.extra, **fields.pop("extra", {})}
    return Frame(**{**vars(frame), **fields, "extra": extra})


def translation(x: float, y: float = 0.0) -> np.ndarray:
    """(4, 4) moving by ``x, y`` on the floor."""
    m = np.eye(4)
    m[:2, 3] = x, y
    return m


def odom_base(stamp_ns: int) -> np.ndarray:
    """The robot's motion: 0.1 m/s forward, 0.05 rad/s turning (T_odom_base)."""
    t = (stamp_ns - T0) * 1e-9
    m = np.eye(4)
    m[:3, :3] = Rotation.from_euler("z", 0.05 * t).as_matrix()
    m[:3, 3] = [0.1 * t, 0.02 * t, 0.0]
    return m


def head_of(camera_to_base: np.ndarray) -> np.ndarray:
    """T_base_head such that base -> head -> camera_link -> optical is ``camera_to_base``."""
    return camera_to_base @ np.linalg.inv(HEAD_LINK @ LINK_OPTICAL)


def encode_depth(depth: np.ndarray, encoding: str) -> np.ndarray:
    """What the camera driver publishes: millimetres (0 invalid) or metres (NaN invalid)."""
    d = depth.astype(np.float32).copy()
    d[:3] = 0.0  # a few invalid rows, as real sensors have
    if encoding == "16UC1":
        return np.where(np.isfinite(d), np.round(d * 1000), 0).astype(np.uint16)
    d[d == 0] = np.nan
    return d


def decoded_depth(depth: np.ndarray, encoding: str) -> np.ndarray:
    """The depth in metres that the bag holds (what predict must see)."""
    enc = encode_depth(depth, encoding)
    return enc.astype(np.float32) / 1000.0 if encoding == "16UC1" else enc


def png_bytes(array: np.ndarray) -> bytes:
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(array).save(buf, format="PNG")
    return buf.getvalue()


class BagBuilder:
    def __init__(self, store) -> None:
        self.store, self.t = store, store.types

    def header(self, stamp_ns: int, frame_id: str):
        t = self.t
        stamp = t["builtin_interfaces/msg/Time"](sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9)
        return t["std_msgs/msg/Header"](stamp=stamp, frame_id=frame_id)

    def image(self, stamp_ns: int, array: np.ndarray, encoding: str, pad: int = 0):
        """An Image; ``pad`` extra bytes per row exercise ``step``."""
        h, w = array.shape[:2]
        rows = np.ascontiguousarray(array).view(np.uint8).reshape(h, -1)
        if pad:
            rows = np.concatenate([rows, np.full((h, pad), 7, np.uint8)], 1)
        return self.t["sensor_msgs/msg/Image"](
            header=self.header(stamp_ns, CAMERA),
            height=h,
            width=w,
            encoding=encoding,
            is_bigendian=0,
            step=rows.shape[1],
            data=rows.reshape(-1),
        )

    def compressed(self, stamp_ns: int, data: bytes, fmt: str):
        return self.t["sensor_msgs/msg/CompressedImage"](
            header=self.header(stamp_ns, CAMERA), format=fmt, data=np.frombuffer(data, np.uint8)
        )

    def camera_info(self, stamp_ns: int, intr, shape):
        fx, fy, cx, cy = (float(v) for v in intr)
        k = np.array([fx, 0, cx, 0, fy, cy, 0, 0, 1], float)
        p = np.array([fx, 0, cx, 0, 0, fy, cy, 0, 0, 0, 1, 0], float)
        t = self.t
        roi = t["sensor_msgs/msg/RegionOfInterest"](
            x_offset=0, y_offset=0, height=0, width=0, do_rectify=False
        )
        return t["sensor_msgs/msg/CameraInfo"](
            header=self.header(stamp_ns, CAMERA),
            height=shape[0],
            width=shape[1],
            distortion_model="plumb_bob",
            d=np.zeros(5),
            k=k,
            r=np.eye(3).reshape(-1),
            p=p,
            binning_x=0,
            binning_y=0,
            roi=roi,
        )

    def tf(self, items):
        """A TFMessage of ``(stamp_ns, parent, child, T_parent_child)`` items."""
        t = self.t
        transforms = []
        for stamp_ns, parent, child, m in items:
            x, y, z, w = Rotation.from_matrix(m[:3, :3]).as_quat()
            transforms.append(
                t["geometry_msgs/msg/TransformStamped"](
                    header=self.header(stamp_ns, parent),
                    child_frame_id=child,
                    transform=t["geometry_msgs/msg/Transform"](
                        translation=t["geometry_msgs/msg/Vector3"](
                            x=float(m[0, 3]), y=float(m[1, 3]), z=float(m[2, 3])
                        ),
                        rotation=t["geometry_msgs/msg/Quaternion"](x=x, y=y, z=z, w=w),
                    ),
                )
            )
        return t["tf2_msgs/msg/TFMessage"](transforms=transforms)


def predict_cli(*argv) -> int:
    """``momakitchen predict ARGV`` (values may be paths and numbers)."""
    from momakitchen.cli.main import main

    return main(["predict", *map(str, argv)])


def one_line_error(capsys) -> str:
    """The command's stderr, checked to be one line without a traceback."""
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    return err


def read_output_bag(path: Path) -> dict[str, list]:
    """Topic -> ``(schema name, log time, message)`` of every message in the MCAP of the
    bag directory ``path``, decoded by the reference MCAP reader (not rosbags, which wrote
    it)."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    (mcap_file,) = path.glob("*.mcap")
    out: dict[str, list] = {}
    with mcap_file.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for schema, channel, message, msg in reader.iter_decoded_messages():
            out.setdefault(channel.topic, []).append((schema.name, message.log_time, msg))
    return out


def hidden_entries(root: Path) -> list[str]:
    """Hidden names under ``root``: what a failed write would leave behind."""
    return sorted(str(p.relative_to(root)) for p in root.rglob(".*"))


def write_bag(
    path: Path,
    frames: list[Frame],
    *,
    storage: str = "sqlite3",
    depth_encoding: str = "16UC1",
    rgb_encoding: str = "bgr8",
    compressed_masks: bool = False,
    skip_topics: tuple[str, ...] = (),
    skip_tf: tuple[str, ...] = (),
    mask_delay_ns: int = RGB_DELAY_NS,
    odom=odom_base,
    odom_end_ns: int | None = None,
) -> Path:
    """Record ``frames`` (stamped :func:`frame_stamps`) into a ROS 2 bag at ``path``.

    ``rgb_encoding``: an Image encoding (rgb8, bgr8, bgra8) or "png" / "jpeg" for a
    CompressedImage. ``skip_topics`` / ``skip_tf`` (child frames) leave parts out.
    ``odom``: stamp (ns) -> T_odom_base, the robot's motion; ``odom_end_ns``: odometry
    stops there (else 0.6 s after the last frame).
    """
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    b = BagBuilder(store)
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    msgs: list[tuple[int, str, str, object]] = []  # (log time, topic, type, message)

    def add(topic, msgtype, stamp, msg):
        if topic not in skip_topics:
            msgs.append((stamp, topic, msgtype, msg))

    static = [
        (T0, "head_link", "camera_link", HEAD_LINK),
        (T0, "camera_link", CAMERA, LINK_OPTICAL),
    ]
    add(
        "/tf_static", "tf2_msgs/msg/TFMessage", T0, b.tf([s for s in static if s[2] not in skip_tf])
    )
    stamps = frame_stamps(len(frames))
    # odom -> base_link at 30 Hz over the whole recording
    odom_end = stamps[-1] + 600_000_000 if odom_end_ns is None else odom_end_ns
    for stamp in range(T0 + 500_000_000, odom_end, 33_333_333):
        if "base_link" not in skip_tf:
            add(
                "/tf",
                "tf2_msgs/msg/TFMessage",
                stamp,
                b.tf([(stamp, "odom", "base_link", odom(stamp))]),
            )
    img = "sensor_msgs/msg/Image"
    comp = "sensor_msgs/msg/CompressedImage"
    for frame, stamp in zip(frames, stamps, strict=True):
        encoding = frame.extra.get("depth_encoding", depth_encoding)
        # The head holds still while the frame is taken (robot_state_publisher rate).
        for dt in (-20_000_000, 20_000_000):
            if "head_link" not in skip_tf and not frame.extra.get("no_head_tf"):
                add(
                    "/tf",
                    "tf2_msgs/msg/TFMessage",
                    stamp + dt,
                    b.tf([(stamp + dt, "base_link", "head_link", head_of(frame.camera_to_base))]),
                )
        add(
            DEPTH,
            img,
            stamp,
            b.image(stamp, encode_depth(frame.depth, encoding), encoding, pad=4),
        )
        add(
            INFO,
            "sensor_msgs/msg/CameraInfo",
            stamp,
            b.camera_info(stamp, frame.intrinsics, frame.depth.shape),
        )
        rs = stamp + RGB_DELAY_NS
        if rgb_encoding in ("png", "jpeg"):
            from PIL import Image

            buf = io.BytesIO()
            Image.fromarray(frame.rgb).save(buf, format=rgb_encoding.upper(), quality=95)
            add(
                RGB,
                comp,
                rs,
                b.compressed(rs, buf.getvalue(), f"rgb8; {rgb_encoding} compressed bgr8"),
            )
        else:
            pixels = {
                "rgb8": frame.rgb,
                "bgr8": frame.rgb[..., ::-1],
                "bgra8": np.concatenate(
                    [frame.rgb[..., ::-1], np.full_like(frame.rgb[..., :1], 255)], -1
                ),
            }[rgb_encoding]
            add(RGB, img, rs, b.image(rs, pixels, rgb_encoding))
        ms = stamp + mask_delay_ns
        for topic, mask in ((MASK, frame.target), (OBSTACLES, frame.obstacle)):
            mono = mask.astype(np.uint8) * 255
            if compressed_masks:
                add(
                    topic,
                    comp,
                    ms,
                    b.compressed(ms, png_bytes(mono), "mono8; png compressed mono8"),
                )
            else:
                add(topic, img, ms, b.image(ms, mono, "mono8"))
    msgs.sort(key=lambda m: m[0])
    with Writer(path, version=9, storage_plugin=plugin) as writer:
        conns = {}
        for _, topic, msgtype, _ in msgs:
            if topic not in conns:
                conns[topic] = writer.add_connection(topic, msgtype, typestore=store)
        for stamp, topic, msgtype, msg in msgs:
            writer.write(conns[topic], stamp, store.serialize_cdr(msg, msgtype))
    return path
