"""Dataset producers: the registry of per-scene functions the generator runs, and how a
run's config is recorded and compared in the manifest."""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable
from typing import Any

from momakitchen import codec
from momakitchen.errors import MomaError
from momakitchen.fileio import dumps_strict
from momakitchen.registry import Registry

SceneFn = Callable[[int, Any], Any]  # (scene_id, config) -> SceneRecords


@dataclasses.dataclass(frozen=True)
class Producer:
    """A registered producer: the stable ``name`` that manifests record, the function and
    the type of its config. Producers register where they are defined (the simulator-backed
    ``"kitchen"`` in :mod:`momakitchen.generation.producer`)."""

    name: str
    scene_fn: SceneFn
    config_type: type


PRODUCERS: Registry[Producer] = Registry("producer")


def producer_name(scene_fn: SceneFn) -> str:
    """The registered name of ``scene_fn``; an unregistered (user's) producer is recorded by
    its import path."""
    for entry in PRODUCERS.values():
        if entry.scene_fn is scene_fn:
            return entry.name
    return f"{scene_fn.__module__}.{scene_fn.__qualname__}"


def config_dict(config: Any) -> dict[str, Any]:
    """The config as plain JSON data (tuples become lists), as stored in the manifest
    (:func:`momakitchen.codec.to_dict`: fields added later appear only once set)."""
    if not dataclasses.is_dataclass(config) or isinstance(config, type):
        raise MomaError(f"generation config must be a dataclass, got {type(config).__name__}")
    return json.loads(dumps_strict(codec.to_dict(config)))


def config_class(config: Any) -> str:
    return f"{type(config).__module__}.{type(config).__qualname__}"


def _first_difference(a: Any, b: Any, path: str = "config") -> str | None:
    if isinstance(a, dict) and isinstance(b, dict):
        for key in sorted(set(a) | set(b)):
            if key not in a or key not in b:
                return f"{path}.{key}"
            diff = _first_difference(a[key], b[key], f"{path}.{key}")
            if diff:
                return diff
        return None
    return None if a == b else path
