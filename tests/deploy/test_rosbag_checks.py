"""predict --bag checks every selected frame before the model runs: in a recording of three
frames whose third is bad (empty or depthless mask, no valid depth, a resized stream, an
unknown encoding, millimetres as metres, a camera info without focal length, no TF or no
odometry at its stamp), the error is one line naming the topic and the frame's index and
stamp, the status 2, nothing is written and no prediction is made."""

from __future__ import annotations

import importlib

import numpy as np
import pytest

pytest.importorskip("rosbags")

from bag_helpers import (
    DEPTH,
    INFO,
    MASK,
    RGB,
    TOPICS,
    Frame,
    changed,
    episode_frames,
    frame_stamps,
    hidden_entries,
    one_line_error,
    png_bytes,
    predict_cli,
    quarter,
    write_bag,
)

from momakitchen.deploy.rosbag import BagFrames, BagTopics
from momakitchen.errors import MomaError

THIRD = "depth frame 2 at t=1700000003.000 s: "


@pytest.fixture(scope="module")
def good(real_view) -> list[Frame]:
    """Three good quarter-resolution frames (the episode's two views, then the first)."""
    small = quarter(episode_frames(real_view))
    return [small[0], small[1], small[0]]


@pytest.fixture
def no_model(monkeypatch):
    """The model must not run: every check comes first."""

    def never(*args, **kwargs):
        raise AssertionError("the model ran before every frame was checked")

    monkeypatch.setattr(importlib.import_module("momakitchen.deploy.predict"), "predict", never)


def _no_valid_depth_on_target(f: Frame) -> Frame:
    depth = f.depth.copy()
    depth[f.target] = 0.0
    return changed(f, depth=depth)


BAD_THIRD = {
    "empty target mask": (
        lambda f: changed(f, target=np.zeros_like(f.target)),
        f"the target mask on {MASK!r} is empty (0 pixels)",
    ),
    "target without depth": (
        _no_valid_depth_on_target,
        f"the target mask on {MASK!r} has",
    ),
    "no valid depth": (
        lambda f: changed(f, depth=np.zeros_like(f.depth)),
        f"the depth image on {DEPTH!r} has no valid pixel (all 0 or NaN)",
    ),
    "resized colour": (
        lambda f: changed(f, rgb=np.ascontiguousarray(f.rgb[:-2])),
        f"the colour image on {RGB!r} is",
    ),
    "colour encoding on the depth topic": (
        lambda f: changed(f, extra={"depth_encoding": "bgr8"}),
        f"depth topic {DEPTH!r} has encoding 'bgr8'; expected 16UC1",
    ),
    "millimetres as 32FC1 metres": (
        lambda f: changed(f, depth=f.depth * 1000, extra={"depth_encoding": "32FC1"}),
        f"the depth image on {DEPTH!r} looks like millimetres",
    ),
    "camera info without focal length": (
        lambda f: changed(f, intrinsics=np.array([np.nan, np.nan, 10.0, 10.0])),
        f"camera info on {INFO!r} has a K that is not 9 finite numbers",
    ),
    "no TF of the head at its stamp": (
        lambda f: changed(f, extra={"no_head_tf": True}),
        "no /tf transform 'base_link' -> 'head_link' at t=1700000003.000 s",
    ),
}


@pytest.mark.parametrize("case", list(BAD_THIRD))
def test_a_bad_third_frame_is_found_before_the_model_runs(case, good, tmp_path, capsys, no_model):
    make_bad, message = BAD_THIRD[case]
    bag = write_bag(tmp_path / "rec", [good[0], good[1], make_bad(good[2])], storage="mcap")
    out = tmp_path / "out"
    argv = ["--bag", bag, *TOPICS, "--every", 1, "--robot", "panda", "--out", out]
    assert predict_cli(*argv) == 2
    err = one_line_error(capsys)
    assert THIRD + message in err, err
    assert not out.exists() and not hidden_entries(tmp_path)
    # The same from Python: opening the bag raises, before any frame is yielded.
    topics = BagTopics(DEPTH, INFO, rgb=RGB, target_mask=MASK)
    with pytest.raises(MomaError, match=r"depth frame 2 at t=1700000003\.000 s"):
        BagFrames(bag, topics, every=1)
    # Only the selected frames are checked: the second (2 s after the bag's start) passes.
    with BagFrames(bag, topics, time=2.0) as frames:
        assert [f.index for f in frames] == [1]


def test_a_target_mask_file_is_checked_against_every_frame(good, tmp_path, capsys, no_model):
    bag = write_bag(tmp_path / "rec", good, storage="mcap")
    mask = tmp_path / "mask.png"
    mask.write_bytes(png_bytes(np.full((10, 12), 255, np.uint8)))
    out = tmp_path / "out"
    argv = ["--bag", bag, "--depth-topic", DEPTH, "--camera-info-topic", INFO, "--every", 1]
    assert predict_cli(*argv, "--target-mask", mask, "--robot", "panda", "--out", out) == 2
    h, w = good[0].depth.shape
    err = one_line_error(capsys)
    assert f"depth frame 0 at t=1700000001.000 s: the target mask from {str(mask)!r}" in err
    assert f"is 12x10, the depth image {w}x{h}" in err
    assert not out.exists()


def test_missing_odometry_at_a_selected_frame(good, tmp_path, capsys, no_model):
    # odometry stops 0.2 s after the second frame: the third has no pose
    end = frame_stamps(3)[1] + 200_000_000
    bag = write_bag(tmp_path / "rec", good, storage="mcap", odom_end_ns=end)
    out = tmp_path / "out"
    argv = ["--bag", bag, *TOPICS, "--every", 1, "--robot", "panda", "--out", out]
    assert predict_cli(*argv, "--odom-frame", "odom") == 2
    err = one_line_error(capsys)
    assert THIRD + "no odometry pose: no /tf transform 'odom' -> 'base_link' at t=" in err, err
    # an odometry frame that is not in the TF tree at all: no path from the base frame
    assert predict_cli(*argv, "--odom-frame", "map") == 2
    err = one_line_error(capsys)
    assert "depth frame 0 at t=1700000001.000 s: no odometry pose: no TF path from the base " in err
    assert "frame 'base_link' to 'map'" in err
    assert predict_cli(*argv, "--odom-frame", "base_link") == 2
    assert "the odometry frame must be a frame other than the base frame" in one_line_error(capsys)
    assert not out.exists() and not hidden_entries(tmp_path)
