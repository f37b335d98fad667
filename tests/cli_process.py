"""``momakitchen`` run in a process of its own, from this checkout's sources (for tests
that signal it, or talk to it over a socket)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"
_MAIN = "import sys; from momakitchen.cli.main import main; sys.exit(main())"


def cli_process(*args: str) -> tuple[list[str], dict[str, str]]:
    """The argv and environment that run ``momakitchen ARGS...`` in a new process."""
    path = os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")])
    env = {**os.environ, "PYTHONPATH": path}
    return [sys.executable, "-c", _MAIN, *args], env
