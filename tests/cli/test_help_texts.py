"""Help texts a new user reads first: examples keep their line breaks, each command
describes itself, and the test runner's configured options keep `pytest -q`'s summary."""

from __future__ import annotations

import re
from pathlib import Path

from momakitchen.cli.main import main

ROOT = Path(__file__).resolve().parents[2]


def test_generate_help_keeps_its_yaml_example(capsys):
    assert main(["generate", "--help"]) == 0
    out = capsys.readouterr().out
    assert "\n    views:\n      episodes: 4\n    cloud:\n      voxel: 0.03\n" in out


def test_evaluate_help_describes_evaluate(capsys):
    assert main(["evaluate", "--help"]) == 0
    out = capsys.readouterr().out
    assert "Map metrics of a trained model" in out and "fits a model" not in out


def test_configured_pytest_options_leave_the_summary_line():
    # (tomllib is Python >= 3.11; the line is simple enough to read directly)
    line = re.search(r"^addopts = (.*)$", (ROOT / "pyproject.toml").read_text(), re.M)
    assert line is not None
    addopts = line.group(1).strip('"').split()
    assert "-q" not in addopts and "--quiet" not in addopts
