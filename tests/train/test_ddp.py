import json
import os
import shutil
import subprocess
import sys

import pytest


@pytest.mark.slow
def test_two_process_torchrun_run_completes(tmp_path):
    """Two processes, with a checkpoint after every batch (rank 0's clock decides, every
    rank sums its loss into it): the run completes and counts every sample once."""
    torchrun = shutil.which("torchrun")
    cmd = [torchrun] if torchrun else [sys.executable, "-m", "torch.distributed.run"]
    out = tmp_path / "ddp"
    env = dict(os.environ, OMP_NUM_THREADS="1")
    proc = subprocess.run(
        [
            *cmd,
            "--nproc_per_node",
            "2",
            "--master_port",
            "29533",
            "-m",
            "momakitchen.train.ddp_smoke",
            "--out",
            str(out),
            "--episodes",
            "8",
            "--epochs",
            "2",
            "--batch-size",
            "2",
            "--checkpoint-minutes",
            "1e-9",
        ],
        capture_output=True,
        text=True,
        timeout=300,
        env=env,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    summary = json.loads(proc.stdout.strip().splitlines()[-1])
    assert summary["world_size"] == 2
    # 8 episodes sharded over 2 processes, batch 2: 2 steps per process per epoch
    assert summary["steps_per_process"] == 4
    assert summary["samples_per_epoch"] == 8
    assert (out / "model.safetensors").is_file() and (out / "loss_curve.png").is_file()
