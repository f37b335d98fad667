"""Argument types and output helpers shared by subcommands.

Each rule on a value has one wording, stated here once: ``expected an integer >= 1, got
'0'``, ``expected a number > 0, got '0'``, ``--config must be in [0, 9], got 12``.
"""

from __future__ import annotations

import argparse
import math
import os
import tempfile
from pathlib import Path

from momakitchen.errors import MomaError
from momakitchen.fileio import existing_dir, existing_file


def _integer(text: str, minimum: int) -> int:
    """argparse type body: an integer >= ``minimum``, with the bad value in the message."""
    try:
        value = int(text)
    except ValueError:
        value = None
    if value is None or value < minimum:
        raise argparse.ArgumentTypeError(f"expected an integer >= {minimum}, got {text!r}")
    return value


def non_negative_int(text: str) -> int:
    """argparse type: an integer >= 0."""
    return _integer(text, 0)


def positive_int(text: str) -> int:
    """argparse type: an integer >= 1."""
    return _integer(text, 1)


def part_arg(text: str) -> tuple[int, int]:
    """argparse type: ``K/N``, part K of N (1 <= K <= N)."""
    k, sep, n = text.partition("/")
    if sep and k.isdigit() and n.isdigit() and 1 <= int(k) <= int(n):
        return int(k), int(n)
    raise argparse.ArgumentTypeError(f"expected K/N with 1 <= K <= N, got {text!r}")


def _number(text: str, allow_zero: bool) -> float:
    rule = ">= 0" if allow_zero else "> 0"
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and (value >= 0 if allow_zero else value > 0)):
        raise argparse.ArgumentTypeError(f"expected a finite number {rule}, got {text!r}")
    return value


def non_negative_float(text: str) -> float:
    """argparse type: a finite number >= 0."""
    return _number(text, allow_zero=True)


def positive_float(text: str) -> float:
    """argparse type: a finite number > 0."""
    return _number(text, allow_zero=False)


def scene_id(text: str) -> int:
    """argparse type: a scene id, in [0, MAX_SCENE_ID] (:mod:`momakitchen.scene.ids`)."""
    from momakitchen.scene.ids import MAX_SCENE_ID, scene_id_problem

    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a scene id (an integer in [0, {MAX_SCENE_ID}]), got {text!r}"
        ) from None
    problem = scene_id_problem(value)
    if problem:
        raise argparse.ArgumentTypeError(problem)
    return value


def check_config_index(index: int, count: int) -> None:
    """MomaError unless ``--config`` ``index`` names one of ``count`` configurations."""
    if not 0 <= index < count:
        raise MomaError(f"--config must be in [0, {count - 1}], got {index}")


def planned_output_dir(path: str | os.PathLike) -> Path:
    """Check, creating nothing, that ``path`` is or can become a writable directory: a
    command checks its ``--out`` with this before any work and creates it (with
    :func:`output_dir`) only when its inputs have proved valid, so a failed run leaves no
    empty directory behind."""
    out = Path(path)
    first_missing, ancestor = None, out
    while not ancestor.exists() and ancestor != ancestor.parent:
        first_missing, ancestor = ancestor, ancestor.parent
    if not ancestor.is_dir():
        reason = f"{str(ancestor)!r} is not a directory"
    elif not os.access(ancestor, os.W_OK | os.X_OK):
        reason = f"{str(ancestor)!r} is not writable"
    else:
        # Permissions say little for root or on special file systems (/proc): try it, and
        # leave nothing behind.
        try:
            if first_missing is None:
                with tempfile.NamedTemporaryFile(dir=out, prefix=".write-test-"):
                    pass
            else:
                first_missing.mkdir()
                first_missing.rmdir()
            return out
        except OSError as exc:
            reason = exc.strerror or str(exc)
    raise MomaError(f"cannot write to output directory {str(out)!r}: {reason}")


def output_dir(path: str | os.PathLike) -> Path:
    """Create ``path`` (and parents) and check it is writable; raise MomaError otherwise."""
    out = planned_output_dir(path)
    try:
        out.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=out, prefix=".write-test-"):
            pass
    except OSError as exc:
        raise MomaError(f"cannot write to output directory {str(out)!r}: {exc.strerror}") from None
    return out


def output_file(path: str | os.PathLike) -> Path:
    """Check, before any work, that file ``path`` can be written later (its directory is or
    can become writable, and it is not a directory)."""
    out = Path(path)
    if out.is_dir():
        raise MomaError(f"cannot write {str(out)!r}: it is a directory")
    if out.exists() and not out.is_file():
        # A device or a pipe (/dev/full, /dev/stdout): the atomic rename would replace it.
        raise MomaError(f"cannot write {str(out)!r}: it is not a regular file")
    planned_output_dir(out.parent)
    return out


def checked_run_dir(run_dir: str) -> Path:
    """A ``--checkpoint`` that exists (``bundled``, ``body``: a shipped model's directory)."""
    from momakitchen.train.checkpoint import SHIPPED_CHECKPOINTS, shipped_checkpoint

    return (
        shipped_checkpoint(run_dir)
        if run_dir in SHIPPED_CHECKPOINTS
        else existing_dir(run_dir, "checkpoint directory")
    )


def checked_methods(args: argparse.Namespace) -> list[tuple[str, str | None]]:
    """Check ``--checkpoint`` directories, ``--predictions`` files and their ``--name``s
    before any work; the ``(file, name or None)`` pair of each predictions file."""
    for run_dir in args.checkpoint:
        checked_run_dir(run_dir)
    for path in args.predictions:
        existing_file(path, "predictions file")
    if args.name and len(args.name) != len(args.predictions):
        raise MomaError(
            f"{len(args.name)} --name for {len(args.predictions)} --predictions: give one "
            "name per predictions file, in order, or none"
        )
    return list(zip(args.predictions, args.name or [None] * len(args.predictions), strict=True))
