"""Replacing a directory whole: new contents are written into a hidden sibling, which then
takes the directory's place by renames, so a reader finds the old contents or the new,
never a mixture, and a failure leaves the old contents where they were."""

from __future__ import annotations

import os
import secrets
import shutil
import tempfile
from pathlib import Path

from momakitchen.errors import MomaError
from momakitchen.fileio import DISK_FULL, disk_full_message


def stage_beside(target: str | os.PathLike) -> Path:
    """A new hidden directory beside ``target`` (in its nearest existing ancestor, so that
    nothing is created at ``target``'s place before the contents are complete), on the
    same file system, so that :func:`swap_in` needs only renames."""
    target = Path(target)
    if target.is_symlink():  # beside what the link points to: swap_in replaces that
        target = target.resolve()
    ancestor = target.parent
    while not ancestor.exists() and ancestor != ancestor.parent:
        ancestor = ancestor.parent
    try:
        return Path(tempfile.mkdtemp(prefix=f".{target.name}.partial-", dir=ancestor))
    except OSError as exc:
        if exc.errno in DISK_FULL:
            raise MomaError(disk_full_message(target, exc)) from None
        raise MomaError(
            f"cannot write beside {str(target)!r} in {str(ancestor)!r}: {exc.strerror or exc}"
        ) from None


def swap_in(stage: Path, target: str | os.PathLike) -> Path | None:
    """Put the directory ``stage`` at ``target``, replacing what is there.

    The old ``target`` is renamed aside, ``stage`` renamed onto its place, and the old one
    removed. If the second rename fails the first is undone, so ``target`` keeps its old
    contents; either way a failure is a MomaError. (Between the renames ``target`` is
    briefly absent: POSIX has no portable atomic exchange of two directories.) Returns
    where the old contents still are if they could not all be removed, else None.
    """
    target = Path(target)
    if target.is_symlink():  # replace what the link points to, and keep the link
        target = target.resolve()
    existed = os.path.lexists(target)
    moved = None  # where the old contents are while they are not at target
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        if existed:
            aside = target.with_name(f".{target.name}.old-{os.getpid()}-{secrets.token_hex(4)}")
            os.rename(target, aside)
            moved = aside
        try:
            os.rename(stage, target)
        except OSError:
            if moved is not None:
                os.rename(moved, target)
                moved = None
            raise
    except OSError as exc:
        if exc.errno in DISK_FULL:
            reason = disk_full_message(target, exc)
        else:
            reason = f"cannot write {str(target)!r}: {exc.strerror or exc}"
        if moved is not None:
            reason += f"; its previous contents are in {str(moved)!r}"
        elif existed:
            reason += "; its previous contents are unchanged"
        raise MomaError(reason) from None
    if moved is not None:
        shutil.rmtree(moved, ignore_errors=True)
        if os.path.lexists(moved):
            return moved
    return None
