"""analyses/blend_weights.py: a fine-tuned run's weights moved toward its start."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
import torch
from safetensors.torch import load_file

from momakitchen.errors import MomaError
from momakitchen.train.checkpoint import shipped_checkpoint

SCRIPT = Path(__file__).resolve().parents[1] / "blend_weights.py"
BODY = shipped_checkpoint("body")  # fine-tuned from the bundled weights


@pytest.fixture
def blend(monkeypatch):
    monkeypatch.syspath_prepend(str(SCRIPT.parent))
    from blend_weights import blend

    return blend


def test_the_ends_are_the_run_and_its_start_and_the_middle_is_between(blend, tmp_path):
    for alpha in ("0", "0.5", "1"):
        blend(BODY, float(alpha), tmp_path / alpha)
    run = load_file(str(BODY / "model.safetensors"))
    start = load_file(str(shipped_checkpoint("bundled") / "model.safetensors"))
    ends = {a: load_file(str(tmp_path / a / "model.safetensors")) for a in ("0", "0.5", "1")}
    assert all(torch.equal(ends["1"][k], v) for k, v in run.items())
    widened = 0
    for k, v in run.items():
        if not v.is_floating_point():
            continue
        if start[k].shape == v.shape:
            assert torch.equal(ends["0"][k], start[k]), k
        else:  # an input layer the fine-tune widened: the start's columns, zeros beside
            widened += 1
            assert (ends["0"][k] != 0).sum() <= start[k].numel(), k
        assert torch.allclose(ends["0.5"][k], (ends["0"][k] + v) / 2, atol=1e-6), k
    assert widened == 4  # the descriptor's and the reachability's new input columns
    assert not torch.equal(ends["0"]["backbone.fp1.mlp.0.weight"], run["backbone.fp1.mlp.0.weight"])
    # the copy keeps the run's inputs and gates
    assert json.loads((tmp_path / "0.5" / "config.json").read_text()) == json.loads(
        (BODY / "config.json").read_text()
    )


def test_bad_input_is_one_line_and_writes_nothing(blend, tmp_path):
    dst = tmp_path / "dst"
    for run, why in [
        (shipped_checkpoint("bundled"), "was not fine-tuned"),
        (tmp_path / "nope", "nope"),
    ]:
        with pytest.raises(MomaError, match=why):
            blend(run, 0.5, dst)
        assert not dst.exists()
    dst.mkdir()
    with pytest.raises(MomaError, match="exists"):
        blend(BODY, 0.5, dst)
    assert list(dst.iterdir()) == []
    out = subprocess.run(
        [sys.executable, str(SCRIPT), str(BODY), "1.5", str(tmp_path / "other")],
        capture_output=True,
        text=True,
    )
    assert out.returncode == 2
    assert out.stderr == "blend_weights.py: error: ALPHA must be in [0, 1], got 1.5\n"
    assert not (tmp_path / "other").exists()
