"""A checkpoint whose weights are finite but overflow (every 2-D weight x1e30, so every
affordance is NaN): one line naming the checkpoint from ``predict`` (exit 2, nothing
written), from the Python API, and a 500 with one line of JSON from ``serve``; no output
ever holds NaN."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
import torch

import momakitchen
from momakitchen.cli.main import main
from momakitchen.data.episode import SEMANTIC_CLASSES
from momakitchen.data.shard import SceneShard
from momakitchen.models.inference import NonFiniteOutput
from momakitchen.train.checkpoint import (
    DEFAULT_CHECKPOINT,
    WEIGHTS_FILE,
    load_checkpoint,
    save_weights,
)

TARGET = SEMANTIC_CLASSES.index("target")


@pytest.fixture(scope="module")
def overflowing(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A copy of the bundled run with every 2-D weight multiplied by 1e30 (still finite)."""
    run_dir = tmp_path_factory.mktemp("broken") / "overflow"
    shutil.copytree(DEFAULT_CHECKPOINT, run_dir)
    run = load_checkpoint(run_dir)
    with torch.no_grad():
        for p in run.model.parameters():
            if p.ndim == 2:
                p.mul_(1e30)
    assert all(bool(torch.isfinite(p).all()) for p in run.model.parameters())
    save_weights(run_dir / WEIGHTS_FILE, run.model)
    return run_dir


@pytest.fixture(scope="module")
def episode(real_view):
    with SceneShard(real_view / "scenes" / "scene_000003.h5") as shard:
        return shard.episode(0, shard.episode_indices(0)[0])


def test_the_api_raises_naming_the_checkpoint(overflowing, episode):
    run = load_checkpoint(overflowing)  # loads: the weights themselves are finite
    for mc in (0, 2):
        with pytest.raises(NonFiniteOutput, match="non-finite affordances") as info:
            momakitchen.predict(
                episode.depth,
                episode.intrinsics,
                episode.camera_to_base,
                episode.semantic == TARGET,
                episode.robot,
                checkpoint=run,
                mc_samples=mc,
            )
        assert str(overflowing) in str(info.value) and info.value.checkpoint == overflowing


def test_predict_exits_2_with_one_line_and_writes_nothing(overflowing, episode, tmp_path, capsys):
    np.save(tmp_path / "depth.npy", episode.depth)
    np.save(tmp_path / "mask.npy", episode.semantic == TARGET)
    np.savetxt(tmp_path / "tf.txt", episode.camera_to_base)
    out = tmp_path / "out"
    argv = ["predict", "--depth", str(tmp_path / "depth.npy"), "--intrinsics"]
    argv += [repr(float(v)) for v in episode.intrinsics]
    argv += ["--extrinsics", str(tmp_path / "tf.txt"), "--target-mask"]
    argv += [str(tmp_path / "mask.npy"), "--robot", episode.robot, "--mc-samples", "0"]
    argv += ["--checkpoint", str(overflowing), "--out", str(out)]
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert captured.err.count("\n") == 1, captured.err
    assert captured.err.startswith("momakitchen predict: error: checkpoint ")
    assert str(overflowing) in captured.err and "non-finite affordances" in captured.err
    assert "NaN" not in captured.out and not out.exists()


def test_serve_answers_500_with_one_line_of_json(overflowing, episode):
    pytest.importorskip("aiohttp")
    from server_helpers import multipart, npy, post, running

    from momakitchen.deploy.server import ModelServer

    server = ModelServer(load_checkpoint(overflowing))
    fields = {
        "intrinsics": " ".join(repr(float(v)) for v in episode.intrinsics),
        "camera_to_base": " ".join(repr(float(v)) for v in episode.camera_to_base.ravel()),
        "robot": episode.robot,
        "mc_samples": "0",
    }
    files = {"depth": npy(episode.depth), "target_mask": npy(episode.semantic == TARGET)}
    with running(server) as addr:
        status, doc, headers = post(addr, *multipart(fields, files))
        assert status == 500 and headers["Content-Type"].startswith("application/json")
        assert set(doc) == {"error"} and "\n" not in doc["error"]
        assert doc["error"].startswith("checkpoint 'overflow' gave non-finite affordances")
        assert str(overflowing.parent) not in doc["error"]  # the name, not the server's path
        # the server stays up and says so
        status, doc, _ = post(addr, *multipart(fields, {**files, "depth": b"GIF"}))
        assert status == 400
