"""A damaged checkpoint (truncated weights, tensors of other names or shapes than its
config.json describes, one flipped byte, a NaN weight): one line naming the file, exit 2,
on every command that loads one."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import torch
from safetensors.torch import load_file

from momakitchen import codec
from momakitchen.cli.main import main
from momakitchen.data.config import GenerationConfig
from momakitchen.errors import MomaError
from momakitchen.train import load_checkpoint

KINDS = ("truncated", "shapes", "names", "flipped", "nan")


@pytest.fixture(scope="module")
def damaged(tiny_run: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Copies of the tiny run: truncated weights, a wider model, another model's name, one
    flipped byte in the tensor data, one NaN weight (saved with a matching checksum)."""
    from momakitchen.train.checkpoint import safetensors_bytes

    root = tmp_path_factory.mktemp("damaged")
    runs = {}
    for kind in KINDS:
        run = root / kind
        shutil.copytree(tiny_run, run)
        config = json.loads((run / "config.json").read_text())
        if kind == "truncated":
            with open(run / "model.safetensors", "r+b") as fh:
                fh.truncate(1000)
        elif kind == "flipped":
            raw = bytearray((run / "model.safetensors").read_bytes())
            raw[-7] ^= 0x01  # the last tensor's data: still parses, checksum differs
            (run / "model.safetensors").write_bytes(bytes(raw))
        elif kind == "nan":
            state = load_file(run / "model.safetensors")
            name = sorted(k for k, v in state.items() if v.is_floating_point())[0]
            state[name].view(-1)[0] = torch.nan
            data = safetensors_bytes(state, {"format": "momakitchen-checkpoint"})
            (run / "model.safetensors").write_bytes(data)
        elif kind == "shapes":
            config["train_config"]["model_config"]["embed_dim"] *= 2
        else:
            config["model"] = config["train_config"]["model"] = "pointnet2"
        (run / "config.json").write_text(json.dumps(config))
        runs[kind] = run
    return runs


@pytest.fixture(scope="module")
def kitchen_manifest(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A dataset directory whose manifest says the simulator made it (msr reads it before
    it loads the checkpoints); it has no shard."""
    from momakitchen.data import manifest as mf

    root = tmp_path_factory.mktemp("kitchen")
    gen = GenerationConfig()
    m = mf.new_manifest(mf.KITCHEN, codec.to_dict(gen), "momakitchen.data.config.GenerationConfig")
    mf.save_manifest(root, mf.finalize(m, complete=True))
    return root


@pytest.mark.parametrize(
    ("kind", "needle"),
    [
        ("truncated", "unreadable"),
        ("shapes", "has shape"),
        ("names", "is missing"),
        ("flipped", "does not match the SHA-256"),
        ("nan", "NaN or infinite"),
    ],
)
def test_load_checkpoint_names_the_file(damaged, kind, needle):
    with pytest.raises(MomaError, match=needle) as info:
        load_checkpoint(damaged[kind])
    text = str(info.value)
    assert "model.safetensors" in text and "\n" not in text


@pytest.mark.parametrize("command", ["evaluate", "predict", "demo", "msr"])
@pytest.mark.parametrize("kind", KINDS)
def test_every_command_reports_a_damaged_checkpoint(
    command, kind, damaged, kitchen_manifest, tmp_path, capsys
):
    run = str(damaged[kind])
    out = tmp_path / "out"
    if command == "evaluate":
        argv = ["evaluate", "--data", str(kitchen_manifest), "--json", str(out / "e.json")]
    elif command == "msr":
        argv = ["msr", "--data", str(kitchen_manifest), "--json", str(out / "m.json")]
    elif command == "demo":
        argv = ["demo", "--out", str(out)]
    else:
        depth, mask, tf = tmp_path / "d.npy", tmp_path / "m.npy", tmp_path / "tf.txt"
        np.save(depth, np.ones((24, 32), np.float32))
        target = np.zeros((24, 32), bool)
        target[5:9, 10:14] = True
        np.save(mask, target)
        np.savetxt(tf, np.eye(4))
        argv = ["predict", "--depth", str(depth), "--intrinsics", "30", "30", "16", "12"]
        argv += ["--extrinsics", str(tf), "--target-mask", str(mask), "--robot", "panda"]
        argv += ["--out", str(out)]
    assert main([*argv, "--checkpoint", run]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert f"{run}/model.safetensors" in err and "Traceback" not in err
    assert not out.exists()


def test_written_weights_carry_a_checksum(tiny_run):
    """Weights and trainer state record the SHA-256 of their data in their own metadata."""
    from safetensors import safe_open

    for name in ("model.safetensors", "trainer_state.safetensors"):
        with safe_open(str(tiny_run / name), "pt") as fh:
            assert len(fh.metadata()["sha256"]) == 64


def test_bundled_weights_carry_a_checksum():
    from safetensors import safe_open

    from momakitchen.train.checkpoint import default_checkpoint

    with safe_open(str(default_checkpoint() / "model.safetensors"), "pt") as fh:
        assert len(fh.metadata()["sha256"]) == 64
