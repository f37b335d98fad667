"""predict --bag replaces its output directory whole or not at all: when the old outputs
cannot be replaced, or the disk fills while the new ones are written, the error is one line
naming the output, the status 2, and the previous outputs are all there, unchanged and
unmixed with new files; a directory holding anything else is refused before any work."""

from __future__ import annotations

import errno
import importlib
import json
import os
import pathlib

import pytest

pytest.importorskip("rosbags")

from bag_helpers import (
    TOPICS,
    episode_frames,
    hidden_entries,
    one_line_error,
    predict_cli,
    quarter,
    write_bag,
)

from momakitchen.deploy import dirswap

OLD = {
    "frames.json": b"old index\n",
    "ros/metadata.yaml": b"old metadata\n",
    "ros/ros.mcap": b"old bag",
    "frame_000000/prediction.json": b"old frame 0\n",
    "frame_000002/prediction.png": b"old picture",
}


def _files(root: pathlib.Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()
    }


def _seed(out: pathlib.Path) -> None:
    """Outputs of an earlier run (an --every run with more frames)."""
    for name, data in OLD.items():
        (out / name).parent.mkdir(parents=True, exist_ok=True)
        (out / name).write_bytes(data)


@pytest.fixture(scope="module")
def bag(real_view, tmp_path_factory) -> pathlib.Path:
    small = quarter(episode_frames(real_view))
    return write_bag(tmp_path_factory.mktemp("bag") / "rec", small[:1], storage="mcap")


def _argv(bag, out, *extra):
    return ["--bag", bag, *TOPICS, *extra, "--robot", "panda", "--mc-samples", 0, "--out", out]


@pytest.mark.parametrize("form", ["directory", "link to a directory"])
def test_success_replaces_the_old_outputs_whole(form, bag, tmp_path):
    out = tmp_path / "out"
    _seed(out)
    given = out
    if form == "link to a directory":  # the link stays, pointing at the new outputs
        given = tmp_path / "latest"
        given.symlink_to(out, target_is_directory=True)
    assert predict_cli(*_argv(bag, given, "--time", 0)) == 0
    assert given.is_symlink() == (form != "directory")
    files = _files(out)
    # one frame: its files at the top; nothing of the earlier run is left to mix in
    assert sorted(files) == [
        "frames.json",
        "prediction.json",
        "prediction.png",
        "ros/metadata.yaml",
        "ros/ros.mcap",
    ]
    assert json.loads(files["frames.json"])["frames"][0]["index"] == 0
    assert files["ros/ros.mcap"].startswith(b"\x89MCAP")
    assert not hidden_entries(tmp_path)


@pytest.mark.parametrize("which", ["old aside", "new in place"])
def test_an_output_directory_that_cannot_be_replaced(which, bag, tmp_path, capsys, monkeypatch):
    """Either rename of the swap fails (a busy mount point, a read-only parent, a race):
    the old outputs stay, whole."""
    out = tmp_path / "out"
    _seed(out)
    real_rename = os.rename

    def rename(src, dst):
        failing = out.name if which == "old aside" else f".{out.name}.partial-"
        if pathlib.Path(src).name.startswith(failing):
            raise OSError(errno.EBUSY, os.strerror(errno.EBUSY), os.fspath(src))
        return real_rename(src, dst)

    monkeypatch.setattr(dirswap.os, "rename", rename)
    assert predict_cli(*_argv(bag, out, "--every", 1)) == 2
    err = one_line_error(capsys)
    assert f"cannot write {str(out)!r}: Device or resource busy" in err, err
    assert "its previous contents are unchanged" in err
    assert _files(out) == OLD
    assert not hidden_entries(tmp_path)


def test_a_directory_with_other_files_is_refused_before_any_work(
    bag, tmp_path, capsys, monkeypatch
):
    def never(*args, **kwargs):
        raise AssertionError("the model ran")

    monkeypatch.setattr(importlib.import_module("momakitchen.deploy.predict"), "predict", never)
    out = tmp_path / "out"
    _seed(out)
    (out / "notes.txt").write_text("mine")
    assert predict_cli(*_argv(bag, out, "--every", 1)) == 2
    err = one_line_error(capsys)
    assert (
        f"output directory {str(out)!r} holds what predict --bag does not write (notes.txt)" in err
    )
    assert _files(out) == {**OLD, "notes.txt": b"mine"}
    assert not hidden_entries(tmp_path)


def _full(path, data: bytes) -> None:
    """A write that fills the disk half-way, as a real one does."""
    with open(path, "wb") as fh:
        fh.write(data[: len(data) // 2])
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def _full_mcap(self, *args, **kwargs):
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


@pytest.mark.parametrize("what", ["prediction.json", "ros", "frames.json"])
def test_a_full_disk_names_the_output_and_keeps_the_old_ones(
    what, bag, tmp_path, capsys, monkeypatch
):
    out = tmp_path / "out"
    _seed(out)
    if what == "ros":
        from rosbags.rosbag2.storage_mcap import McapWriter

        monkeypatch.setattr(McapWriter, "close", _full_mcap)  # the bag's index and summary
    else:
        real = pathlib.Path.write_bytes
        stem = what.split(".")[0]

        def write_bytes(self, data):
            return _full(self, data) if self.name.startswith(f".{stem}.") else real(self, data)

        monkeypatch.setattr(pathlib.Path, "write_bytes", write_bytes)
    assert predict_cli(*_argv(bag, out, "--every", 1)) == 2
    err = one_line_error(capsys)
    named = {
        "prediction.json": out / "frame_000000" / "prediction.json",
        "ros": out / "ros",
        "frames.json": out / "frames.json",
    }[what]
    assert f"cannot write {str(named)!r}: No space left on device" in err, err
    assert _files(out) == OLD
    assert not hidden_entries(tmp_path)


def test_write_prediction_bag_replaces_a_bag_whole(tmp_path, monkeypatch):
    """The Python writer: a second bag replaces the first; a failed one leaves it."""
    import numpy as np
    from bag_helpers import read_output_bag

    from momakitchen.deploy.rosout import StampedFusion, StampedPrediction, write_prediction_bag
    from momakitchen.errors import MomaError
    from momakitchen.models.inference import Prediction

    def prediction(x: float) -> Prediction:
        floor = np.array([[x, 0.0, 0.0], [x + 0.1, 0.2, 0.0]])
        return Prediction(
            floor, np.array([0.9, 0.1]), np.zeros(2), np.array([[x, 0.0, 0.5]]),
            np.array([0.9]), np.zeros(1), np.array([x + 1.0, 0.0, 0.8]), "panda", "navaff",
        )  # fmt: skip

    path = tmp_path / "bag"
    write_prediction_bag(path, [StampedPrediction(10, "base_link", prediction(1.0))])
    fused = StampedFusion(20, "odom", np.array([[3.0, 4.0]]), np.ones(1), np.zeros(1), (3, 4, 1))
    write_prediction_bag(path, [StampedPrediction(20, "base_link", prediction(2.0))], fusion=fused)
    msgs = read_output_bag(path)
    ((_, _, goal),) = msgs["/momakitchen/goal"]
    assert goal.pose.position.x == 2.0  # the second bag's, alone
    ((_, _, fused_goal),) = msgs["/momakitchen/fused_goal"]
    assert fused_goal.header.frame_id == "odom" and fused_goal.pose.position.y == 4.0
    before = _files(path)

    def refused(src, dst):
        raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), os.fspath(src))

    monkeypatch.setattr(dirswap.os, "rename", refused)
    with pytest.raises(MomaError, match="its previous contents are unchanged"):
        write_prediction_bag(path, [StampedPrediction(30, "base_link", prediction(3.0))])
    assert _files(path) == before and not hidden_entries(tmp_path)
