"""predict --bag: ROS 2 bags (.db3 and .mcap) written from simulated frames give the same
poses as momakitchen.predict on the same frame; the output bag holds every message as
described; bad bags are one-line errors with nothing written."""

from __future__ import annotations

import importlib
import io
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rosbags")

from bag_helpers import (
    DEPTH,
    FRAME_NS,
    INFO,
    MASK,
    OBSTACLES,
    RGB,
    T0,
    TOPICS,
    BagBuilder,
    Frame,
    decoded_depth,
    episode_frames,
    png_bytes,
    quarter,
    read_output_bag,
    write_bag,
)

import momakitchen
from momakitchen.cli.main import main
from momakitchen.deploy.rosbag import (
    TransformBuffer,
    colour_rgb,
    depth_metres,
    mask_image,
    typestore,
)
from momakitchen.errors import MomaError

# The module (momakitchen.deploy.predict is also the name of its function).
deploy_predict = importlib.import_module("momakitchen.deploy.predict")


@pytest.fixture(scope="module")
def frames(real_view) -> list[Frame]:
    """The two views of a simulated episode (the head tilts between them)."""
    out = episode_frames(real_view)
    assert not np.allclose(out[0].camera_to_base, out[1].camera_to_base)
    return out


@pytest.fixture(scope="module")
def small(frames) -> list[Frame]:
    return quarter(frames)


@pytest.fixture(scope="module")
def run():
    from momakitchen.train.checkpoint import default_checkpoint, load_checkpoint

    return load_checkpoint(default_checkpoint())


def _expected(frame: Frame, encoding: str, run, rgb=None, camera_to_base=None):
    return momakitchen.predict(
        decoded_depth(frame.depth, encoding),
        frame.intrinsics,
        frame.camera_to_base if camera_to_base is None else camera_to_base,
        frame.target,
        frame.extra["robot"],
        rgb=frame.rgb if rgb is None else rgb,
        obstacle_masks=[frame.obstacle],
        checkpoint=run,
        mc_samples=0,
    )


def _cli(*argv) -> int:
    return main(["predict", *map(str, argv)])


def _poses(doc) -> np.ndarray:
    return np.array([[p["x"], p["y"], p["yaw"]] for p in doc["poses"]])


def _same_poses(got: np.ndarray, pred) -> None:
    """Within 1 mm and 0.001 rad (prediction.json rounds to 0.1 mm / 1e-4 rad); ``pred`` a
    Prediction or its (k, 3) poses."""
    poses = getattr(pred, "poses", pred)
    assert got.shape == poses.shape
    np.testing.assert_allclose(got[:, :2], poses[:, :2], rtol=0, atol=1e-3)
    dyaw = np.angle(np.exp(1j * (got[:, 2] - poses[:, 2])))
    assert np.abs(dyaw).max() <= 1e-3


def _check_output_bag(path: Path, preds: list, stamps: list[int], frame_id: str) -> None:
    msgs = read_output_bag(path)
    assert set(msgs) == {
        f"/momakitchen/{t}" for t in ("goal", "poses", "affordance", "markers", "prediction")
    }
    for topic, items in msgs.items():
        assert [t for _, t, _ in items] == stamps, topic
    for i, (pred, stamp) in enumerate(zip(preds, stamps, strict=True)):

        def head(m, stamp=stamp):
            assert m.header.frame_id == frame_id
            assert m.header.stamp.sec * 10**9 + m.header.stamp.nanosec == stamp

        def pose_xyyaw(p):
            q = p.orientation
            assert (q.x, q.y) == (0.0, 0.0) and p.position.z == 0.0
            return [p.position.x, p.position.y, 2 * np.arctan2(q.z, q.w)]

        schema, _, goal = msgs["/momakitchen/goal"][i]
        assert schema == "geometry_msgs/msg/PoseStamped"
        head(goal)
        _same_poses(np.array([pose_xyyaw(goal.pose)]), pred.poses[:1])
        schema, _, arr = msgs["/momakitchen/poses"][i]
        assert schema == "geometry_msgs/msg/PoseArray"
        head(arr)
        _same_poses(np.array([pose_xyyaw(p) for p in arr.poses]), pred)
        schema, _, cloud = msgs["/momakitchen/affordance"][i]
        assert schema == "sensor_msgs/msg/PointCloud2"
        head(cloud)
        names = [f.name for f in cloud.fields]
        assert names == ["x", "y", "z", "affordance", "uncertainty"]
        assert all(f.datatype == 7 and f.count == 1 for f in cloud.fields)  # FLOAT32
        assert [f.offset for f in cloud.fields] == [0, 4, 8, 12, 16] and cloud.point_step == 20
        values = np.frombuffer(bytes(cloud.data), "<f4").reshape(cloud.width, 5)
        np.testing.assert_allclose(values[:, :3], pred.floor_xyz, atol=1e-6)
        np.testing.assert_allclose(values[:, 3], pred.affordance, atol=1e-6)
        np.testing.assert_allclose(values[:, 4], pred.uncertainty, atol=1e-6)
        schema, _, markers = msgs["/momakitchen/markers"][i]
        assert schema == "visualization_msgs/msg/MarkerArray"
        ms = markers.markers
        assert ms[0].action == 3  # DELETEALL clears the previous frame's
        k = len(pred.poses)
        arrows = [m for m in ms if m.ns == "poses"]
        texts = [m for m in ms if m.ns == "scores"]
        (target,) = [m for m in ms if m.ns == "target"]
        assert len(arrows) == len(texts) == k and len(ms) == 2 * k + 2
        assert all(m.type == 0 and m.action == 0 for m in arrows)
        for m in ms[1:]:
            head(m)
        _same_poses(np.array([pose_xyyaw(m.pose) for m in arrows]), pred)
        assert texts[0].text == f"1: {pred.pose_scores[0]:.2f}" and texts[0].type == 9
        np.testing.assert_allclose(
            [target.pose.position.x, target.pose.position.y, target.pose.position.z],
            pred.target_xyz,
            atol=1e-6,
        )
        assert target.type == 2
        schema, _, string = msgs["/momakitchen/prediction"][i]
        assert schema == "std_msgs/msg/String"
        assert json.loads(string.data) == pred.to_dict(floor_points=False)


def test_db3_bag_16uc1_every_frame_matches_predict(frames, run, tmp_path):
    bag = write_bag(
        tmp_path / "rec", frames, storage="sqlite3", depth_encoding="16UC1", rgb_encoding="bgr8"
    )
    assert (bag / "rec.db3").is_file()
    out = tmp_path / "out"
    robot = frames[0].extra["robot"]
    assert (
        _cli("--bag", bag, *TOPICS, "--every", 1, "--robot", robot, "--mc-samples", 0, "--out", out)
        == 0
    )
    summary = json.loads((out / "frames.json").read_text())["frames"]
    assert [f["index"] for f in summary] == [0, 1]
    preds = []
    for frame, item in zip(frames, summary, strict=True):
        expected = _expected(frame, "16UC1", run)
        doc = json.loads((out / item["outputs"] / "prediction.json").read_text())
        _same_poses(_poses(doc), expected)
        assert (out / item["outputs"] / "prediction.png").stat().st_size > 10_000
        # the TF chain base -> head (/tf, interpolated) -> camera_link -> optical (static)
        np.testing.assert_allclose(item["camera_to_base"], frame.camera_to_base, atol=1e-8)
        assert item["paired_dt"] == {"rgb": 0.004, "target mask": 0.004, "obstacle mask 0": 0.004}
        preds.append(expected)
    _check_output_bag(out / "ros", preds, FRAME_NS, "base_link")


def test_mcap_bag_32fc1_compressed_images_at_a_time(frames, run, tmp_path):
    bag = write_bag(
        tmp_path / "rec",
        frames,
        storage="mcap",
        depth_encoding="32FC1",
        rgb_encoding="png",
        compressed_masks=True,
    )
    (single,) = bag.glob("*.mcap")
    robot = frames[1].extra["robot"]
    expected = _expected(frames[1], "32FC1", run)
    # --time picks the depth frame recorded nearest 1.9 s after the bag's start (T0): #1;
    # the bag directory and its .mcap file alone read the same.
    for path, out in ((bag, tmp_path / "a"), (single, tmp_path / "b")):
        assert (
            _cli(
                "--bag",
                path,
                *TOPICS,
                "--time",
                1.9,
                "--robot",
                robot,
                "--mc-samples",
                0,
                "--out",
                out,
            )
            == 0
        )
        doc = json.loads((out / "prediction.json").read_text())  # one frame: at the top
        _same_poses(_poses(doc), expected)
        summary = json.loads((out / "frames.json").read_text())["frames"]
        assert [f["index"] for f in summary] == [1] and summary[0]["base_frame"] == "base_link"
        np.testing.assert_allclose(
            summary[0]["camera_to_base"], frames[1].camera_to_base, atol=1e-8
        )
        _check_output_bag(out / "ros", [expected], FRAME_NS[1:], "base_link")


def test_the_python_api(frames, run, tmp_path):
    from momakitchen.deploy.rosbag import BagFrames, BagTopics, predict_bag

    bag = write_bag(tmp_path / "rec", frames, storage="mcap")
    topics = BagTopics(DEPTH, INFO, rgb=RGB, target_mask=MASK, obstacle_masks=(OBSTACLES,))
    with BagFrames(bag, topics, every=2) as selected:
        assert len(selected) == 1  # frames 0, 2, ... of two
        (frame,) = list(selected)
    assert frame.index == 0 and frame.stamp_ns == FRAME_NS[0] and frame.rgb.dtype == np.uint8
    np.testing.assert_array_equal(frame.target_mask, frames[0].target)
    np.testing.assert_array_equal(frame.depth, decoded_depth(frames[0].depth, "16UC1"))
    ((bag_frame, pred),) = predict_bag(
        bag, topics, frames[0].extra["robot"], time=0.0, checkpoint=run, mc_samples=0
    )
    assert bag_frame.index == 0
    _same_poses(pred.poses, _expected(frames[0], "16UC1", run))


def test_target_mask_file_and_no_colour(frames, run, tmp_path):
    bag = write_bag(tmp_path / "rec", frames[:1], storage="mcap")
    mask = tmp_path / "mask.png"
    mask.write_bytes(png_bytes(frames[0].target.astype(np.uint8) * 255))
    out = tmp_path / "out"
    argv = ["--bag", bag, "--depth-topic", DEPTH, "--camera-info-topic", INFO, "--time", 0]
    assert _cli(*argv, "--target-mask", mask, "--robot", "panda", "--out", out) == 0
    expected = momakitchen.predict(
        decoded_depth(frames[0].depth, "16UC1"),
        frames[0].intrinsics,
        frames[0].camera_to_base,
        frames[0].target,
        "panda",
        checkpoint=run,
    )
    _same_poses(_poses(json.loads((out / "prediction.json").read_text())), expected)


# ------------------------------------------------------------------ encodings and TF
def _image(store, array, encoding, pad=0, bigendian=False):
    b = BagBuilder(store)
    msg = b.image(T0, array, encoding, pad=pad)
    if bigendian:
        swapped = np.ascontiguousarray(array).byteswap()
        msg = b.image(T0, swapped, encoding, pad=pad)
        msg.is_bigendian = 1
    return msg


def test_image_encodings():
    store = typestore()
    rng = np.random.default_rng(0)
    rgb = rng.integers(0, 256, (5, 7, 3), dtype=np.uint8)
    img = "sensor_msgs/msg/Image"
    for enc, pixels in {
        "rgb8": rgb,
        "bgr8": rgb[..., ::-1],
        "rgba8": np.concatenate([rgb, rgb[..., :1]], -1),
        "bgra8": np.concatenate([rgb[..., ::-1], rgb[..., :1]], -1),
    }.items():
        got = colour_rgb(_image(store, pixels, enc, pad=3), img, "/c")
        np.testing.assert_array_equal(got, rgb, err_msg=enc)
    mm = rng.integers(0, 5000, (5, 7)).astype(np.uint16)
    for big in (False, True):
        got = depth_metres(_image(store, mm, "16UC1", pad=2, bigendian=big), img, "/d")
        np.testing.assert_allclose(got, mm / 1000.0, rtol=1e-6)
    metres = (mm / 1000.0).astype(np.float32)
    metres[0, 0] = np.nan
    got = depth_metres(_image(store, metres, "32FC1"), img, "/d")
    np.testing.assert_array_equal(got, metres)
    b = BagBuilder(store)
    comp = "sensor_msgs/msg/CompressedImage"
    np.testing.assert_array_equal(
        colour_rgb(b.compressed(T0, png_bytes(rgb), "png"), comp, "/c"), rgb
    )
    from PIL import Image

    red = np.zeros((16, 16, 3), np.uint8) + np.array([200, 30, 60], np.uint8)
    buf = io.BytesIO()
    Image.fromarray(red).save(buf, format="JPEG", quality=95)
    jpeg = colour_rgb(b.compressed(T0, buf.getvalue(), "bgr8; jpeg compressed bgr8"), comp, "/c")
    assert jpeg.shape == red.shape and np.abs(jpeg.astype(int) - red).max() <= 3  # RGB order
    # compressed_depth_image_transport: a 12-byte header, then a 16-bit PNG of millimetres
    cd = b.compressed(T0, bytes(12) + png_bytes(mm), "16UC1; compressedDepth png")
    np.testing.assert_allclose(depth_metres(cd, comp, "/d"), mm / 1000.0, rtol=1e-6)
    mask = np.zeros((5, 7), np.uint8)
    mask[1:3, 2:4] = 255
    np.testing.assert_array_equal(mask_image(_image(store, mask, "mono8"), img, "/m"), mask > 0)
    np.testing.assert_array_equal(
        mask_image(b.compressed(T0, png_bytes(mask), "png"), comp, "/m"), mask > 0
    )
    bad = {
        "has encoding 'yuv422'; expected one of rgb8": (
            _image(store, rgb[..., :2].copy(), "rgb8"),
            "yuv422",
            colour_rgb,
        ),
        "expected 16UC1 \\(millimetres": (_image(store, rgb, "rgb8"), None, depth_metres),
        "expected one of rgb8": (_image(store, mm, "16UC1"), None, colour_rgb),
        "expected one of mono8": (_image(store, metres, "32FC1"), None, mask_image),
    }
    for message, (msg, enc, fn) in bad.items():
        if enc:
            msg.encoding = enc
        with pytest.raises(MomaError, match=message):
            fn(msg, img, "/t")
    with pytest.raises(MomaError, match="cannot decode compressed image"):
        colour_rgb(b.compressed(T0, b"\x89PNG not really", "png"), comp, "/c")
    short = _image(store, rgb, "rgb8")
    short.data = short.data[:-5]
    with pytest.raises(MomaError, match="does not hold 7x5 rgb8 pixels"):
        colour_rgb(short, img, "/c")


def test_transform_buffer_composes_and_interpolates():
    from scipy.spatial.transform import Rotation

    store = typestore()
    b = BagBuilder(store)
    tf = TransformBuffer()

    def add(parent, child, stamp, m, static):
        (ts,) = b.tf([(stamp, parent, child, m)]).transforms
        tf.add(parent, child, stamp, ts.transform, static)

    a, c = np.eye(4), np.eye(4)
    a[:3, :3] = Rotation.from_euler("z", 0.0).as_matrix()
    c[:3, :3] = Rotation.from_euler("z", 1.0).as_matrix()
    c[:3, 3] = [2.0, 0.0, 0.0]
    add("odom", "base", 0, a, False)
    add("odom", "base", 10**9, c, False)
    mount = np.eye(4)
    mount[:3, :3] = Rotation.from_euler("xyz", [0.3, -0.2, 0.1]).as_matrix()
    mount[:3, 3] = [0.1, 0.2, 1.0]
    add("base", "cam", 0, mount, True)
    mid = tf.lookup("odom", "base", 250_000_000)
    np.testing.assert_allclose(mid[:3, 3], [0.5, 0, 0], atol=1e-12)
    np.testing.assert_allclose(
        Rotation.from_matrix(mid[:3, :3]).as_euler("xyz"), [0, 0, 0.25], atol=1e-12
    )
    np.testing.assert_allclose(tf.lookup("odom", "cam", 10**9), c @ mount, atol=1e-12)
    np.testing.assert_allclose(
        tf.lookup("cam", "odom", 10**9), np.linalg.inv(c @ mount), atol=1e-12
    )
    with pytest.raises(MomaError, match=r"no /tf transform 'odom' -> 'base' at t=2\.000 s"):
        tf.lookup("odom", "cam", 2 * 10**9)
    with pytest.raises(
        MomaError,
        match=r"no TF path from the camera frame 'cam' to 'map'.*"
        r"\['base', 'cam', 'odom'\]",
    ):
        tf.lookup("map", "cam", 0)


# ------------------------------------------------------------------ bad bags
def _bad(capsys, argv, out) -> str:
    assert _cli(*argv, "--robot", "panda", "--mc-samples", 0, "--out", out) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert not out.exists()  # nothing half-written
    return err


def test_bad_bags_are_one_line_errors_with_nothing_written(small, tmp_path, capsys, monkeypatch):
    out = tmp_path / "out"
    args = ["--every", 1, *TOPICS]
    good = write_bag(tmp_path / "good", small, storage="mcap")
    err = _bad(capsys, ["--bag", good, *args, "--depth-topic", "/camera/depth/nope"], out)
    assert "depth topic '/camera/depth/nope' is not in the bag" in err
    assert f"{DEPTH} (sensor_msgs/msg/Image)" in err and "/tf (tf2_msgs/msg/TFMessage)" in err
    err = _bad(capsys, ["--bag", good, *args, "--camera-info-topic", RGB], out)
    assert "has type sensor_msgs/msg/Image, expected sensor_msgs/msg/CameraInfo" in err
    err = _bad(capsys, ["--bag", good, *args, "--base-frame", "map"], out)
    assert "no TF path from the camera frame 'camera_color_optical_frame' to 'map'" in err
    assert "'base_link', 'camera_color_optical_frame', 'camera_link', 'head_link', 'odom'" in err
    err = _bad(capsys, ["--bag", good, *TOPICS, "--time", 99], out)
    assert "time 99 s is past the end of the bag (" in err
    err = _bad(capsys, ["--bag", good, *args, "--depth-topic", RGB], out)
    assert f"depth topic {RGB!r} has encoding 'bgr8'; expected 16UC1" in err
    # the camera's mount missing from /tf_static: the tree splits in two
    nomount = write_bag(tmp_path / "nomount", small, skip_tf=("camera_link",))
    err = _bad(capsys, ["--bag", nomount, *args], out)
    assert "(connected to 'camera_color_optical_frame': ['camera_link'])" in err
    assert "no TF path from the camera frame 'camera_color_optical_frame' to 'base_link'" in err
    # the segmenter's masks 0.2 s late: nothing to pair within 0.05 s
    late = write_bag(tmp_path / "late", small, mask_delay_ns=200_000_000)
    err = _bad(capsys, ["--bag", late, *args], out)
    assert f"depth frame 0 at t=1700000001.000 s: no target mask message on {MASK!r}" in err
    assert "within 0.05 s of the depth image" in err
    assert "nearest is 0.200 s away" in err
    late_ok = tmp_path / "late_ok"
    assert (
        _cli(
            "--bag",
            late,
            *args,
            "--max-dt",
            0.25,
            "--robot",
            "panda",
            "--mc-samples",
            0,
            "--out",
            late_ok,
        )
        == 0
    )
    # truncated bags, both storages
    for storage in ("sqlite3", "mcap"):
        bag = write_bag(tmp_path / f"cut_{storage}", small, storage=storage)
        (data,) = [p for p in bag.iterdir() if p.suffix in (".db3", ".mcap")]
        data.write_bytes(data.read_bytes()[: data.stat().st_size // 2])
        err = _bad(capsys, ["--bag", bag, *args], out)
        assert f"bag {str(bag)!r} is unreadable (truncated or damaged?)" in err, err
    err = _bad(capsys, ["--bag", tmp_path / "none", *args], out)
    assert "does not exist" in err
    # the model fails on the second frame: found when its turn comes, after the first
    # frame's outputs were written (into a hidden directory, removed again)
    calls = []

    def second_fails(*args, **kwargs):
        calls.append(1)
        if len(calls) == 2:
            raise MomaError("no floor is visible (no point on the fitted floor plane)")
        return real_predict(*args, **kwargs)

    real_predict = deploy_predict.predict
    monkeypatch.setattr(deploy_predict, "predict", second_fails)
    err = _bad(capsys, ["--bag", good, *args], out)
    assert "depth frame 1 at t=1700000002.000 s: no floor is visible" in err and len(calls) == 2
    assert not [p.name for p in tmp_path.iterdir() if p.name.startswith(".")]
    shutil.rmtree(late_ok)
