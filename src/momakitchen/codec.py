"""One codec for every config dataclass: plain JSON data out, checked dataclasses back in.

:func:`to_dict` turns a (nested) dataclass into JSON-ready data (tuples become lists); a
field declared with ``metadata=OMIT_IF_DEFAULT`` is left out while it holds its default
(a field added to a config later: records written before it existed stay the same).
:func:`from_dict` builds a dataclass from such data by its type hints: nested dataclasses,
``tuple[...]`` fields, ``int`` / ``float`` / ``str`` / ``bool`` and ``Optional``. Unknown
keys and wrong types raise :class:`~momakitchen.errors.MomaError` naming the dotted field
path and the bad value; missing keys take the field's default; each dataclass's own
``__post_init__`` validation runs as usual. :func:`load_config_file` reads YAML or JSON.
"""

from __future__ import annotations

import dataclasses
import json
import re
import types
import typing
from collections.abc import Mapping
from pathlib import Path
from typing import Any, TypeVar

import yaml

from momakitchen.errors import MomaError
from momakitchen.fileio import existing_file

T = TypeVar("T")

CONFIG_SUFFIXES = (".yaml", ".yml", ".json")
# Field metadata: to_dict leaves the field out while it holds its default.
OMIT_IF_DEFAULT = types.MappingProxyType({"omit_if_default": True})


def to_dict(obj: Any) -> dict[str, Any]:
    """The fields of dataclass ``obj`` as plain data (nested dicts, lists, scalars), without
    the ``OMIT_IF_DEFAULT`` fields that hold their default."""
    if not dataclasses.is_dataclass(obj) or isinstance(obj, type):
        raise MomaError(f"expected a dataclass instance, got {type(obj).__name__}")
    return {
        f.name: _plain(getattr(obj, f.name))
        for f in dataclasses.fields(obj)
        if not (f.metadata.get("omit_if_default") and getattr(obj, f.name) == f.default)
    }


def _plain(value: Any) -> Any:
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return to_dict(value)
    if isinstance(value, (tuple, list)):
        return [_plain(v) for v in value]
    if isinstance(value, Mapping):
        return {k: _plain(v) for k, v in value.items()}
    return value


def from_dict(cls: type[T], data: Any, *, where: str = "config") -> T:
    """An instance of dataclass ``cls`` built from ``data`` (a mapping of field names).

    ``where`` is the dotted path of ``data`` in messages (``config.views.episodes``).
    """
    if not isinstance(data, Mapping):
        raise MomaError(f"{where} must be a mapping of {cls.__name__} fields, got {data!r}")
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}  # type: ignore[arg-type]
    for key in data:
        if key not in fields:
            raise MomaError(f"unknown key '{where}.{key}'; known keys: {', '.join(fields)}")
    missing = [
        name
        for name, f in fields.items()
        if name not in data
        and f.default is dataclasses.MISSING
        and f.default_factory is dataclasses.MISSING
    ]
    if missing:
        raise MomaError(f"missing key '{where}.{missing[0]}'")
    hints = typing.get_type_hints(cls)
    values = {name: _convert(hints[name], value, f"{where}.{name}") for name, value in data.items()}
    try:
        return cls(**values)
    except MomaError as exc:  # the class's own validation: say where the values came from
        raise MomaError(f"{where}: {exc}") from None


def _type_name(tp: Any) -> str:
    return getattr(tp, "__name__", None) or str(tp).replace("typing.", "")


def _convert(tp: Any, value: Any, where: str) -> Any:
    """``value`` as type ``tp`` (lists become tuples); MomaError naming ``where``."""
    origin = typing.get_origin(tp)
    args = typing.get_args(tp)
    if tp is Any:
        return value
    if origin is typing.Union or origin is types.UnionType:
        if value is None and type(None) in args:
            return None
        options = [a for a in args if a is not type(None)]
        if len(options) == 1:
            return _convert(options[0], value, where)
        for option in options:
            try:
                return _convert(option, value, where)
            except MomaError:
                continue
        raise MomaError(f"{where} must be {' or '.join(map(_type_name, options))}, got {value!r}")
    if dataclasses.is_dataclass(tp) and isinstance(tp, type):
        return from_dict(tp, value, where=where)
    if origin is tuple:
        if not isinstance(value, (list, tuple)):
            raise MomaError(f"{where} must be a list, got {value!r}")
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_convert(args[0], v, f"{where}[{i}]") for i, v in enumerate(value))
        if args and len(value) != len(args):
            raise MomaError(f"{where} must be a list of {len(args)} values, got {value!r}")
        if not args:
            return tuple(value)
        return tuple(
            _convert(a, v, f"{where}[{i}]")
            for i, (a, v) in enumerate(zip(args, value, strict=True))
        )
    if origin is list:
        if not isinstance(value, (list, tuple)):
            raise MomaError(f"{where} must be a list, got {value!r}")
        return [_convert(args[0] if args else Any, v, f"{where}[{i}]") for i, v in enumerate(value)]
    if origin is dict:
        if not isinstance(value, Mapping):
            raise MomaError(f"{where} must be a mapping, got {value!r}")
        kt, vt = args if args else (Any, Any)
        return {_convert(kt, k, where): _convert(vt, v, f"{where}.{k}") for k, v in value.items()}
    if tp is bool:
        if isinstance(value, bool):
            return value
    elif tp is int:
        if isinstance(value, int) and not isinstance(value, bool):
            return value
    elif tp is float:
        # JSON and YAML write whole numbers as ints (``lift_height: 1``).
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return float(value)
    elif isinstance(tp, type):
        if isinstance(value, tp):
            return value
    else:
        return value  # a hint this codec does not check (Literal, Callable, ...)
    raise MomaError(f"{where} must be {_type_name(tp)}, got {value!r}")


class _Loader(yaml.SafeLoader):
    """YAML 1.1 reads ``1e-3`` (no dot) as a string; this loader reads it as a float."""


_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(
        r"""^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+]?[0-9]+)?
                |[-+]?(?:[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)
                |\.[0-9_]+(?:[eE][-+]?[0-9]+)?
                |[-+]?\.(?:inf|Inf|INF)
                |\.(?:nan|NaN|NAN))$""",
        re.X,
    ),
    list("-+0123456789."),
)


def read_config_file(path: str | Path) -> dict[str, Any]:
    """The mapping in a YAML (``.yaml``/``.yml``) or JSON (``.json``) file; MomaError for a
    missing file, another suffix, bad syntax or a top level that is not a mapping."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in CONFIG_SUFFIXES:
        raise MomaError(
            f"config file {str(path)!r}: use {', '.join(CONFIG_SUFFIXES)}, got "
            f"{suffix or 'no suffix'!r}"
        )
    existing_file(path, "config file")
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise MomaError(f"cannot read config file {str(path)!r}: {exc}") from None
    try:
        data = json.loads(text) if suffix == ".json" else yaml.load(text, Loader=_Loader)
    except (json.JSONDecodeError, yaml.YAMLError) as exc:
        detail = " ".join(str(exc).split())  # one line: YAML errors span several
        raise MomaError(
            f"config file {str(path)!r} is not valid "
            f"{'JSON' if suffix == '.json' else 'YAML'}: {detail}"
        ) from None
    if not isinstance(data, dict):
        raise MomaError(
            f"config file {str(path)!r} must hold a mapping of config keys, got "
            f"{'nothing' if data is None else type(data).__name__}"
        )
    return data


def load_config_file(path: str | Path, cls: type[T], *, where: str = "config") -> T:
    """An instance of dataclass ``cls`` from a YAML or JSON file (see :func:`from_dict`);
    messages start with the file's path."""
    data = read_config_file(path)
    try:
        return from_dict(cls, data, where=where)
    except MomaError as exc:
        raise MomaError(f"{path}: {exc}") from None


def merge(base: Mapping[str, Any], update: Mapping[str, Any]) -> dict[str, Any]:
    """``base`` with the keys of ``update`` replaced, recursively into nested mappings
    (a config file that sets some fields of a section keeps the section's other values)."""
    out = dict(base)
    for key, value in update.items():
        old = out.get(key)
        out[key] = (
            merge(old, value) if isinstance(old, Mapping) and isinstance(value, Mapping) else value
        )
    return out
