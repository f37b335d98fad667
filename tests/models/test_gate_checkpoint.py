"""scripts/gate_checkpoint.py: a trained run copied with the robot's reachability gate."""

from __future__ import annotations

import json

import pytest

from momakitchen.errors import MomaError
from momakitchen.train.checkpoint import SHIPPED_CHECKPOINTS, default_checkpoint, read_run_config
from script_helpers import load_script


def _script():
    return load_script("gate_checkpoint")


def test_the_copy_reads_the_gate_and_keeps_the_weights(tmp_path):
    gate = _script()
    assert gate.main(["bundled", str(tmp_path / "gated"), "--width", "0.05"]) == 0
    config, _ = read_run_config(tmp_path / "gated")
    assert config.model_config.reach_gate == 0.05 and config.model_config.reach_points == 8
    weights = "model.safetensors"
    copied = (tmp_path / "gated" / weights).read_bytes()
    assert copied == (default_checkpoint() / weights).read_bytes()
    assert not config.model_config.footprint_gate and config.model_config.index_gate == 0
    assert gate.main(["bundled", str(tmp_path / "both"), "--footprint", "--index", "0.5"]) == 0
    both = read_run_config(tmp_path / "both")[0].model_config
    assert both.footprint_gate and both.index_gate == 0.5
    # a copy of the shipped body (which carries the weight) without --index carries none
    body = str(SHIPPED_CHECKPOINTS["body"])
    assert gate.main([body, str(tmp_path / "plain"), "--footprint"]) == 0
    plain = read_run_config(tmp_path / "plain")[0].model_config
    assert plain.index_gate == 0 and not plain.index_picks_only
    assert gate.main([body, str(tmp_path / "picks"), "--index", "0.5", "--picks-only"]) == 0
    picks = read_run_config(tmp_path / "picks")[0].model_config
    assert picks.index_gate == 0.5 and picks.index_picks_only
    source = json.loads((default_checkpoint() / "config.json").read_text())
    assert "reach_gate" not in source["train_config"]["model_config"]  # the source is untouched


def test_bad_values_and_existing_directories_write_nothing(tmp_path, capsys):
    gate = _script()
    assert gate.main(["bundled", str(tmp_path / "a"), "--width", "5"]) == 2
    assert "reach_gate must be in [0, 1] m" in capsys.readouterr().err
    assert gate.main(["bundled", str(tmp_path / "a"), "--index", "2"]) == 2
    assert "index_gate must be in [0, 1]" in capsys.readouterr().err
    assert gate.main(["bundled", str(tmp_path / "a"), "--picks-only"]) == 2
    assert "index_picks_only needs index_gate > 0" in capsys.readouterr().err
    (tmp_path / "b").mkdir()
    with pytest.raises(MomaError, match="exists"):
        gate.gate_copy(default_checkpoint(), tmp_path / "b", 0.03, 8)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b"]
