"""PyBullet without its build banner on stdout.

PyBullet prints a build banner through C's stdio when it is imported and when a client
connects; it would end up in the middle of command output (or of JSON written to stdout).
The package imports PyBullet through this module (see ``momakitchen/__init__.py``) and
creates clients with :func:`connect_direct`, both with stdout muted.
"""

from __future__ import annotations

import ctypes
import importlib
import os
import sys
from collections.abc import Callable
from typing import TypeVar

T = TypeVar("T")


def _muted(fn: Callable[[], T]) -> T:
    """Call ``fn`` with file descriptor 1 sent to /dev/null (C-level output included)."""
    try:
        fd = sys.stdout.fileno()
    except (AttributeError, OSError, ValueError):  # stdout is not a real file (captured)
        return fn()
    sys.stdout.flush()
    saved = os.dup(fd)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), fd)
            result = fn()
            ctypes.CDLL(None).fflush(None)  # what C buffered goes to /dev/null too
    finally:
        os.dup2(saved, fd)
        os.close(saved)
    return result


p = _muted(lambda: importlib.import_module("pybullet"))


def connect_direct() -> int:
    """A new headless (DIRECT) PyBullet client id."""
    return _muted(lambda: p.connect(p.DIRECT))
