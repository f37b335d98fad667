"""PyBullet without its build banner.

PyBullet's C code prints a build banner when it is imported and may print more when a
client connects; it would turn the CLI's one-line errors into two lines. The package
imports PyBullet through this module (see ``momakitchen/__init__.py``) and creates clients
with :func:`connect_direct`, both with C-level stdout and stderr muted; robots load through
:func:`muted` too (a user's URDF without inertials draws a warning per link, which would
land in the middle of ``robots --json``).
"""

from __future__ import annotations

import ctypes
import importlib
import os
import sys
from collections.abc import Callable
from typing import TypeVar

T = TypeVar("T")


def muted(fn: Callable[[], T]) -> T:
    """Call ``fn`` with file descriptors 1 and 2 sent to /dev/null (C output included)."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (AttributeError, OSError, ValueError):  # not a real file (e.g. captured)
            continue
    # C code writes to the process's descriptors 1 and 2, whatever sys.stdout is.
    fds, saved = [], []
    for fd in (1, 2):
        try:
            saved.append(os.dup(fd))
            fds.append(fd)
        except OSError:  # closed
            continue
    try:
        with open(os.devnull, "w") as null:
            for fd in fds:
                os.dup2(null.fileno(), fd)
            result = fn()
            ctypes.CDLL(None).fflush(None)  # what C buffered goes to /dev/null too
    finally:
        for fd, old in zip(fds, saved, strict=True):
            os.dup2(old, fd)
            os.close(old)
    return result


p = muted(lambda: importlib.import_module("pybullet"))


def connect_direct() -> int:
    """A new headless (DIRECT) PyBullet client id."""
    return muted(lambda: p.connect(p.DIRECT))
