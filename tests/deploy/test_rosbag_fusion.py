"""predict --bag --odom-frame: three frames of a static scene, taken while the base drives
forward along x (odometry x = 1.0, 1.25, 1.5 m) with the camera still in the world, fuse
into one goal in the odometry frame: each frame's pose read from TF at its stamp, the
maps moved by those poses (one target for all three), the goal as MapFusion gives it for
the known poses, facing the target, as a PoseStamped in ``odom`` in the output bag and in
frames.json."""

from __future__ import annotations

import json
import math
import warnings
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

pytest.importorskip("rosbags")

from bag_helpers import (
    DEPTH,
    INFO,
    MASK,
    OBSTACLES,
    RGB,
    T0,
    TOPICS,
    changed,
    episode_frames,
    frame_stamps,
    one_line_error,
    predict_cli,
    quarter,
    read_output_bag,
    translation,
    write_bag,
)

from momakitchen.deploy.fusion import MapFusion
from momakitchen.deploy.rosbag import BagFrames, BagTopics, fuse_frames, predict_bag
from momakitchen.errors import MomaError

XS = [1.0, 1.25, 1.5]  # the base's x in odom at the three frames (1 s apart)


def odom_along_x(stamp_ns: int) -> np.ndarray:
    """T_odom_base: 0.25 m/s forward along odom's x, from x = 1 m at the first frame."""
    t = (stamp_ns - T0) * 1e-9
    return translation(XS[0] + 0.25 * (t - 1.0))


@pytest.fixture(scope="module")
def recording(real_view, tmp_path_factory):
    first = quarter(episode_frames(real_view))[0]
    camera_in_odom = translation(XS[0]) @ first.camera_to_base  # the camera stays put
    frames = [
        changed(first, camera_to_base=np.linalg.inv(translation(x)) @ camera_in_odom) for x in XS
    ]
    path = tmp_path_factory.mktemp("drive") / "rec"
    return write_bag(path, frames, storage="mcap", odom=odom_along_x), first.extra["robot"]


def _pose(msg) -> list[float]:
    q, p = msg.pose.orientation, msg.pose.position
    assert (q.x, q.y, p.z) == (0.0, 0.0, 0.0)
    return [p.x, p.y, 2 * math.atan2(q.z, q.w)]


def test_fused_goal_in_the_odometry_frame(recording, tmp_path):
    bag, robot = recording
    out = tmp_path / "out"
    argv = ["--bag", bag, *TOPICS, "--every", 1, "--odom-frame", "odom", "--robot", robot]
    assert predict_cli(*argv, "--mc-samples", 0, "--out", out) == 0
    doc = json.loads((out / "frames.json").read_text())
    # the poses odometry gave at the frames' stamps
    odom = np.array([f["odom_pose"] for f in doc["frames"]])
    np.testing.assert_allclose(odom, [[x, 0.0, 0.0] for x in XS], atol=1e-6)
    # each frame's target moved by its pose: one place in the world
    looks = [
        json.loads((out / f["outputs"] / "prediction.json").read_text()) for f in doc["frames"]
    ]
    targets = np.array(
        [np.add(p["target_xyz"][:2], [x, 0.0]) for p, x in zip(looks, XS, strict=True)]
    )
    assert np.ptp(targets, axis=0).max() < 0.05, targets
    fused = doc["fused"]
    assert fused["frame"] == "odom" and fused["looks"] == 3
    assert fused["stamp"] == pytest.approx(frame_stamps(3)[-1] * 1e-9)
    np.testing.assert_allclose(fused["target_xy"], targets[-1], atol=1e-3)
    goal = fused["goal"]
    # as MapFusion fuses the three maps (from prediction.json) at the known poses
    fusion = MapFusion(cell=fused["cell"])
    for p, x in zip(looks, XS, strict=True):
        rows = np.array(p["floor_points"]["rows"])
        look = SimpleNamespace(
            floor_xyz=rows[:, :3],
            affordance=rows[:, 3],
            uncertainty=rows[:, 4],
            target_xyz=np.array(p["target_xyz"]),
        )
        fusion.add(look, (x, 0.0, 0.0))
    expected = fusion.goal()
    assert expected is not None
    assert math.dist([goal["x"], goal["y"]], expected.pose[:2]) <= fused["cell"] * 1.5
    assert fused["cells"] == pytest.approx(len(fusion.fused()[0]), rel=0.02)
    # where each look's own best pose, moved into odom, put the base (within 0.25 m)
    for p, x in zip(looks, XS, strict=True):
        best = p["poses"][0]
        assert math.dist([goal["x"], goal["y"]], [best["x"] + x, best["y"]]) < 0.25
    # facing the fused target
    to_target = math.atan2(fused["target_xy"][1] - goal["y"], fused["target_xy"][0] - goal["x"])
    assert abs(math.remainder(goal["yaw"] - to_target, math.tau)) < 1e-4
    # the output bag: the fused goal and map in odom, stamped at the last frame
    msgs = read_output_bag(out / "ros")
    ((schema, log_ns, msg),) = msgs["/momakitchen/fused_goal"]
    assert schema == "geometry_msgs/msg/PoseStamped" and msg.header.frame_id == "odom"
    stamp = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
    assert stamp == log_ns == frame_stamps(3)[-1]
    np.testing.assert_allclose(_pose(msg), [goal["x"], goal["y"], goal["yaw"]], atol=1e-6)
    ((schema, _, cloud),) = msgs["/momakitchen/fused_affordance"]
    assert schema == "sensor_msgs/msg/PointCloud2" and cloud.header.frame_id == "odom"
    values = np.frombuffer(bytes(cloud.data), "<f4").reshape(cloud.width, 5)
    assert cloud.width == fused["cells"] and (values[:, 2] == 0).all()
    assert ((values[:, 3] >= 0) & (values[:, 3] <= 1)).all()
    # the per-frame messages stay in the base frame, one per frame
    assert [m.header.frame_id for _, _, m in msgs["/momakitchen/goal"]] == ["base_link"] * 3

    # The same from Python.
    topics = BagTopics(
        DEPTH, INFO, rgb=RGB, target_mask=MASK, obstacle_masks=(OBSTACLES,), odom_frame="odom"
    )
    pairs = predict_bag(bag, topics, robot, every=1, mc_samples=0)
    _, api_goal = fuse_frames(pairs)
    assert api_goal is not None
    np.testing.assert_allclose(api_goal.pose, [goal["x"], goal["y"], goal["yaw"]], atol=1e-5)


def _drive(real_view, path, odom):
    """A three-frame recording whose odometry is ``odom`` (stamp -> T_odom_base)."""
    first = quarter(episode_frames(real_view))[0]
    return write_bag(path, [first] * 3, storage="mcap", odom=odom), first.extra["robot"]


def test_odometry_that_jumps_is_refused_before_any_prediction(real_view, tmp_path, capsys):
    second = frame_stamps(3)[1]

    def jumps(stamp_ns: int) -> np.ndarray:  # 100 m further after the second frame
        return odom_along_x(stamp_ns) @ translation(100.0 if stamp_ns > second + 10**8 else 0.0)

    bag, robot = _drive(real_view, tmp_path / "jump", jumps)
    out = tmp_path / "out"
    argv = ["--bag", bag, *TOPICS, "--every", 1, "--odom-frame", "odom", "--robot", robot]
    assert predict_cli(*argv, "--mc-samples", 0, "--out", out) == 2
    err = one_line_error(capsys)
    assert "the odometry jumps 100.25 m between depth frame 1 at t=1700000002.000 s and " in err
    assert "depth frame 2 at t=1700000003.000 s, 1.000 s apart: more than a base drives" in err
    assert not out.exists()
    topics = BagTopics(DEPTH, INFO, rgb=RGB, target_mask=MASK, odom_frame="odom")
    # a faster base, declared: the same odometry is taken
    with BagFrames(bag, replace(topics, max_odom_speed=100.0), every=1) as frames:
        assert [round(f.odom_pose[0], 2) for f in frames.planned] == [1.0, 1.25, 101.5]
    with pytest.raises(MomaError, match=r"max_odom_speed must be in \(0, 100\] m/s, got nan"):
        replace(topics, max_odom_speed=float("nan"))


@pytest.mark.parametrize("axis", [0, 1])
def test_infinite_odometry_is_named_at_its_coordinate(real_view, tmp_path, axis):
    second = frame_stamps(3)[1]

    def broken(stamp_ns: int) -> np.ndarray:  # the samples around the second frame
        m = odom_along_x(stamp_ns)
        if abs(stamp_ns - second) < 40_000_000:
            m[axis, 3] = np.inf
        return m

    bag, _ = _drive(real_view, tmp_path / "inf", broken)
    topics = BagTopics(DEPTH, INFO, rgb=RGB, target_mask=MASK, odom_frame="odom")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no NumPy warning before the error
        with pytest.raises(MomaError) as info:
            BagFrames(bag, topics, every=1)
    message = str(info.value)
    assert message.startswith("depth frame 1 at t=1700000002.000 s: ")
    assert "/tf transform 'odom' -> 'base_link' at t=" in message
    assert f"has {'xy'[axis]} = inf: not a finite number" in message and "nan" not in message
