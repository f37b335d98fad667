"""The checkpoint shipped in the package: present, loadable, and the default everywhere."""

from __future__ import annotations

import dataclasses
import json

from momakitchen.train import load_checkpoint, preset_config
from momakitchen.train.checkpoint import DEFAULT_CHECKPOINT, default_checkpoint


def test_bundled_checkpoint_loads_and_is_small():
    run = load_checkpoint(default_checkpoint(), model="navaff")
    assert run.config.preset == "cpu"
    files = {p.name: p.stat().st_size for p in DEFAULT_CHECKPOINT.iterdir()}
    assert {"config.json", "model.safetensors", "CARD.md"} <= set(files)
    assert sum(files.values()) < 5_000_000
    card = (DEFAULT_CHECKPOINT / "CARD.md").read_text()
    assert "momakitchen train" in card and "MSR" in card


def test_bundled_checkpoint_is_the_cpu_preset():
    """The shipped model is what `momakitchen train --model navaff` trains: a change to the
    preset's model or loss needs a new bundled model (or a preset change made on purpose)."""
    run = load_checkpoint(default_checkpoint(), model="navaff")
    # It reads the version-1 descriptor; the preset trains on the current one (a run
    # started from it with `train --init bundled` gets widened weights).
    assert run.config.model_config.descriptor_version == 1
    preset = preset_config("cpu", "navaff").model_config
    assert run.config.model_config == dataclasses.replace(preset, descriptor_version=1)


def test_demo_runs_on_defaults(tmp_path, capsys):
    """The README's first command, with the bundled model."""
    from momakitchen.cli.main import main

    assert main(["demo", "--out", str(tmp_path)]) == 0
    result = json.loads((tmp_path / "result.json").read_text())
    assert result["checkpoint"] == "bundled" and result["model"] == "navaff"
    assert (tmp_path / "report.png").is_file()
    assert "report.png" in capsys.readouterr().out


def test_the_body_model_is_shipped_by_name_and_reads_the_reachability():
    """`--checkpoint body` everywhere: its own directory, its own name in every table."""
    from momakitchen.cli.common import checked_run_dir
    from momakitchen.train.checkpoint import SHIPPED_CHECKPOINTS, resolve_run_dir, run_label

    run = load_checkpoint("body", model="navaff")
    assert run_label(run) == "body" and run_label(load_checkpoint("bundled")) == "bundled"
    assert resolve_run_dir("body") == checked_run_dir("body") == SHIPPED_CHECKPOINTS["body"]
    mc = run.config.model_config
    assert mc.reach_input and mc.footprint_gate and mc.reach_gate > 0 and mc.index_gate == 0.5
    assert mc.index_picks_only  # the weight is left off where the robot opens its target
    assert "reach_m" in mc.hidden_descriptor
    files = {p.name for p in SHIPPED_CHECKPOINTS["body"].iterdir()}
    assert {"config.json", "model.safetensors", "CARD.md"} <= files
