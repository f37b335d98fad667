"""``momakitchen`` run in a process of its own, from this checkout's sources (for tests
that signal it, or talk to it over a socket)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"
_MAIN = "import sys; from momakitchen.cli.main import main; sys.exit(main())"


def cli_process(*args: str) -> tuple[list[str], dict[str, str]]:
    """The argv and environment that run ``momakitchen ARGS...`` in a new process."""
    path = os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")])
    env = {**os.environ, "PYTHONPATH": path}
    return [sys.executable, "-c", _MAIN, *args], env


@contextmanager
def serve_process(*args: str) -> Iterator[str]:
    """``momakitchen serve --host 127.0.0.1 --port 0 ARGS...`` in its own process: yields
    its base URL once it listens, and stops it afterwards."""
    import pytest

    argv, env = cli_process("serve", "--host", "127.0.0.1", "--port", "0", *args)
    proc = subprocess.Popen(
        argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env
    )
    line: list[str] = []
    reader = threading.Thread(target=lambda: line.append(proc.stdout.readline()), daemon=True)
    reader.start()
    reader.join(60)
    match = re.search(r"http://127\.0\.0\.1:(\d+)", line[0] if line else "")
    if not match:
        proc.kill()
        pytest.fail(f"the server did not start: {line} {proc.stderr.read()}")
    try:
        yield f"http://127.0.0.1:{match.group(1)}"
    finally:
        proc.terminate()
        proc.wait(10)
