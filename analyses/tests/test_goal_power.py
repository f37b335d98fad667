"""analyses/goal_power.py: how often the held-out goal is met by chance of the draw."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[1] / "goal_power.py"


def _run(*args: str) -> subprocess.CompletedProcess:
    cmd = [sys.executable, str(SCRIPT), "--draws", "500", *args]
    return subprocess.run(cmd, capture_output=True, text=True, check=False)


def _rows(out: str) -> dict[tuple[int, float], tuple[float, float]]:
    rows = {}
    for line in out.splitlines()[2:]:
        n, share, every, one = (c.strip() for c in line.strip("|").split("|"))
        rows[int(n), float(share)] = (float(every), float(one))
    return rows


def test_more_configurations_resolve_the_goal():
    out = _run("--configurations", "60", "300", "--share", "0.5", "0.95", "1.0", "--beyond", "0")
    assert out.returncode == 0, out.stderr
    rows = _rows(out.stdout)
    # The oracle's own outcomes close the whole gap in every draw; half of it never passes.
    assert rows[60, 1.0] == (1.0, 1.0) and rows[300, 1.0] == (1.0, 1.0)
    assert rows[60, 0.5][1] < 0.01
    # A true share above the bar passes more often the more configurations judge it.
    assert rows[60, 0.95][0] < rows[300, 0.95][0]
    assert rows[60, 0.95][0] <= rows[60, 0.95][1]


def test_bad_rates_are_one_line_errors():
    out = _run("--oracle", "0.1", "--random", "0.2")
    assert out.returncode == 2
    assert "--random < --oracle" in out.stderr and out.stderr.count("\n") == 1
