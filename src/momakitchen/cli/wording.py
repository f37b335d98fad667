"""How the commands print counts: ``1 scene``, ``2 scenes``."""

from __future__ import annotations


def counted(n: int, noun: str, plural: str | None = None) -> str:
    """``n`` and its noun, singular for exactly one (``plural``: where it is not noun + s),
    with thousands separators: ``counted(1, "scene")`` is ``1 scene``,
    ``counted(1200, "episode")`` ``1,200 episodes``."""
    return f"{n:,} {noun if n == 1 else plural or noun + 's'}"
