"""Minimal PLY point-cloud I/O with NumPy (vertex element only; ASCII or binary)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from momakitchen.errors import MomaError

_TYPES = {
    "char": "i1",
    "int8": "i1",
    "uchar": "u1",
    "uint8": "u1",
    "short": "i2",
    "int16": "i2",
    "ushort": "u2",
    "uint16": "u2",
    "int": "i4",
    "int32": "i4",
    "uint": "u4",
    "uint32": "u4",
    "float": "f4",
    "float32": "f4",
    "double": "f8",
    "float64": "f8",
}
_NAMES = {
    "i1": "char",
    "u1": "uchar",
    "i2": "short",
    "u2": "ushort",
    "i4": "int",
    "u4": "uint",
    "f4": "float",
    "f8": "double",
}


def write_ply(path: str | os.PathLike, columns: dict[str, np.ndarray]) -> None:
    """Write a binary little-endian PLY with one vertex property per column.

    Shapes: every column (N,), e.g. ``x, y, z`` float32 and ``red, green, blue`` uint8.
    """
    n = {len(v) for v in columns.values()}
    if len(n) != 1:
        raise MomaError(f"PLY columns must have equal lengths, got {sorted(n)}")
    count = n.pop()
    dtype = np.dtype([(k, np.asarray(v).dtype.newbyteorder("<")) for k, v in columns.items()])
    rows = np.empty(count, dtype)
    for k, v in columns.items():
        rows[k] = v
    header = [
        "ply",
        "format binary_little_endian 1.0",
        "comment momakitchen",
        f"element vertex {count}",
    ]
    for k in columns:
        header.append(f"property {_NAMES[dtype[k].str[1:]]} {k}")
    header.append("end_header")
    Path(path).write_bytes(("\n".join(header) + "\n").encode("ascii") + rows.tobytes())


def read_ply(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """Read the vertex properties of a PLY file (ASCII, binary little or big endian).

    Returns a dict of (N,) arrays by property name. Other elements (faces) must come after
    the vertices and are ignored.
    """
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise MomaError(f"cannot read PLY {path}: {exc.strerror}") from None
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise MomaError(f"{path}: not a PLY file")
    body_start = data.index(b"\n", end) + 1
    lines = data[:end].decode("ascii", "replace").splitlines()
    fmt, count, props, in_vertex, seen_vertex = None, 0, [], False, False
    for line in lines:
        tok = line.split()
        if not tok:
            continue
        if tok[0] == "format":
            fmt = tok[1]
        elif tok[0] == "element":
            in_vertex = tok[1] == "vertex"
            if in_vertex:
                count, seen_vertex = int(tok[2]), True
            elif not seen_vertex:
                raise MomaError(f"{path}: element {tok[1]!r} before the vertices")
        elif tok[0] == "property" and in_vertex:
            if tok[1] == "list":
                raise MomaError(f"{path}: list property in the vertex element")
            if tok[1] not in _TYPES:
                raise MomaError(f"{path}: unknown PLY type {tok[1]!r}")
            props.append((tok[2], _TYPES[tok[1]]))
    if not seen_vertex or not props:
        raise MomaError(f"{path}: no vertex element")
    if fmt == "ascii":
        text = data[body_start:].decode("ascii", "replace").split("\n")[:count]
        try:
            table = np.array([r.split()[: len(props)] for r in text], dtype=np.float64)
        except ValueError:
            raise MomaError(f"{path}: malformed ASCII vertex rows") from None
        if table.shape != (count, len(props)):
            raise MomaError(f"{path}: expected {count} vertices, found {table.shape[0]}")
        return {name: table[:, i].astype(t) for i, (name, t) in enumerate(props)}
    if fmt not in ("binary_little_endian", "binary_big_endian"):
        raise MomaError(f"{path}: unsupported PLY format {fmt!r}")
    order = "<" if fmt == "binary_little_endian" else ">"
    dtype = np.dtype([(name, order + t) for name, t in props])
    if len(data) - body_start < count * dtype.itemsize:
        raise MomaError(f"{path}: truncated ({count} vertices announced)")
    rows = np.frombuffer(data, dtype=dtype, count=count, offset=body_start)
    return {name: rows[name].astype(dtype[name].newbyteorder("=")) for name, _ in props}
