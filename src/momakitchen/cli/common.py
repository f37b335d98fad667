"""Argument types and output helpers shared by subcommands."""

from __future__ import annotations

import argparse
import os
import tempfile
from pathlib import Path

import numpy as np

from momakitchen.errors import MomaError


def non_negative_int(text: str) -> int:
    """argparse type: an integer >= 0, with the bad value in the message."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a non-negative integer, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected a non-negative integer, got {value}")
    return value


def positive_int(text: str) -> int:
    """argparse type: an integer >= 1."""
    value = non_negative_int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {value}")
    return value


def non_negative_float(text: str) -> float:
    """argparse type: a finite number >= 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (np.isfinite(value) and value >= 0):
        raise argparse.ArgumentTypeError(f"expected a finite number >= 0, got {text!r}")
    return value


def output_dir(path: str | os.PathLike) -> Path:
    """Create ``path`` (and parents) and check it is writable; raise MomaError otherwise."""
    out = Path(path)
    try:
        out.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=out, prefix=".write-test-"):
            pass
    except OSError as exc:
        raise MomaError(f"cannot write to output directory {str(out)!r}: {exc.strerror}") from None
    return out
