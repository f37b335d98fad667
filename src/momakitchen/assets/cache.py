"""On-disk cache of generated URDF files, keyed by content hash.

The same parameters give the same URDF text and therefore the same file; PyBullet loads
URDFs from paths, so every built instance is written once and reused.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

from momakitchen.fileio import atomic_write_text


def cache_dir() -> Path:
    """``$MOMAKITCHEN_CACHE`` or ``~/.cache/momakitchen``."""
    root = os.environ.get("MOMAKITCHEN_CACHE") or Path.home() / ".cache" / "momakitchen"
    return Path(root)


def cached_urdf(urdf: str, prefix: str) -> Path:
    """Path of a file holding ``urdf`` (written atomically on first use)."""
    digest = hashlib.sha256(urdf.encode("utf-8")).hexdigest()[:20]
    path = cache_dir() / "urdf" / f"{prefix}-{digest}.urdf"
    if not path.exists():
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(path, urdf)
    return path
