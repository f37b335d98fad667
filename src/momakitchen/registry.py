"""One registry type for everything looked up by name: robots, models, asset categories,
dataset producers.

A :class:`Registry` is a read-only mapping from name to entry with one way in
(:meth:`Registry.register`, which refuses to replace an entry silently) and one error for
unknown names (:class:`~momakitchen.errors.MomaError` listing the known ones).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from typing import Generic, TypeVar

from momakitchen.errors import MomaError

T = TypeVar("T")


class Registry(Mapping[str, T], Generic[T]):
    """Entries of one kind by name, in registration order.

    Args:
        kind: what an entry is, for messages ("robot", "model", ...).
        key: the name of an entry (default: its ``name`` attribute).
        plural: ``kind`` in the plural, for messages (default: ``kind + "s"``).
    """

    def __init__(
        self, kind: str, key: Callable[[T], str] | None = None, *, plural: str | None = None
    ) -> None:
        self.kind = kind
        self.plural = plural or f"{kind}s"
        self._key: Callable[[T], str] = key or (lambda entry: entry.name)  # type: ignore[attr-defined]
        self._entries: dict[str, T] = {}

    def register(self, entry: T, *, replace: bool = False) -> T:
        """Add ``entry`` under its name; MomaError if the name is taken and not ``replace``."""
        name = self._key(entry)
        if name in self._entries and not replace:
            raise MomaError(f"{self.kind} {name!r} is already registered")
        self._entries[name] = entry
        return entry

    def get_entry(self, name: str) -> T:
        """The entry called ``name``; MomaError naming it and listing the known ones."""
        try:
            return self._entries[name]
        except (KeyError, TypeError):
            raise MomaError(
                f"unknown {self.kind} {name!r}; known {self.plural}: {', '.join(self._entries)}"
            ) from None

    def names(self) -> tuple[str, ...]:
        return tuple(self._entries)

    def __getitem__(self, name: str) -> T:
        return self._entries[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._entries)

    def __len__(self) -> int:
        return len(self._entries)

    def __repr__(self) -> str:
        return f"Registry({self.kind!r}, {list(self._entries)})"
