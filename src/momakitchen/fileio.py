"""Atomic file writes (a reader never sees a half-written file), the checks of the
directories and files that commands read, reading a JSON object with a clear error, and
strict JSON text (never NaN or infinity)."""

from __future__ import annotations

import errno
import gzip
import io
import json
import math
import numbers
import os
import zipfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

from momakitchen.errors import MomaError

if TYPE_CHECKING:
    import numpy as np


# The errors of a full disk (or of a full quota): a user's problem, reported as one line.
DISK_FULL = frozenset({errno.ENOSPC, errno.EDQUOT})


def disk_full_message(path: str | os.PathLike, exc: OSError) -> str:
    """The one-line error for a write to ``path`` that failed with a full disk."""
    return (
        f"cannot write {str(path)!r}: {os.strerror(exc.errno or errno.ENOSPC)}; "
        "free some space or write elsewhere"
    )


@contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success it is renamed onto ``path``.

    The temporary name keeps the suffix, so writers that infer a format from it (e.g.
    ``savefig``) work. On error the temporary file is removed and ``path`` is untouched; a
    full disk is a MomaError naming ``path``.
    """
    path = Path(path)
    if path.exists() and not path.is_file() and not path.is_dir():
        # A device or a pipe (/dev/full, a FIFO): the rename would replace it with a file.
        raise MomaError(f"cannot write {str(path)!r}: it is not a regular file")
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp{path.suffix}")
    try:
        yield tmp
        os.replace(tmp, path)
    except OSError as exc:
        if exc.errno in DISK_FULL:
            raise MomaError(disk_full_message(path, exc)) from None
        raise
    finally:
        tmp.unlink(missing_ok=True)


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` via a temporary file and rename."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    atomic_write_bytes(path, text.encode("utf-8"))


def npz_bytes(**arrays: np.ndarray) -> bytes:
    """An ``.npz`` archive (compressed, loadable by ``np.load``) whose bytes depend only on
    the arrays: entries in argument order with a fixed timestamp, unlike ``np.savez``."""
    import numpy as np  # here: the command line imports this module before numpy is needed

    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        for name, array in arrays.items():
            info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            with zf.open(info, "w") as fh:
                np.lib.format.write_array(fh, np.asanyarray(array), allow_pickle=False)
    return buf.getvalue()


def existing_dir(path: str | os.PathLike, what: str) -> Path:
    """``path`` as a Path if it is a directory; otherwise MomaError saying whether it is
    missing or something else (``what`` names it: "dataset directory", ...)."""
    path = Path(path)
    if not path.exists():
        raise MomaError(f"{what} {str(path)!r} does not exist")
    if not path.is_dir():
        raise MomaError(f"{what} {str(path)!r} is not a directory")
    return path


def existing_file(path: str | os.PathLike, what: str) -> Path:
    """``path`` as a Path if it is a regular file; otherwise MomaError saying whether it is
    missing or a directory (``what`` names it: "depth file", "config file", ...)."""
    path = Path(path)
    if not path.exists():
        raise MomaError(f"{what} {str(path)!r} does not exist")
    if not path.is_file():
        raise MomaError(f"{what} {str(path)!r} is not a file")
    return path


def read_json_object(path: str | os.PathLike) -> dict[str, Any]:
    """The JSON object in ``path`` (gzipped or not: archives keep large results as
    ``.json.gz``); MomaError naming the file if it cannot be read, is not JSON or holds
    something other than an object."""
    path = Path(path)
    try:
        raw = path.read_bytes()
        if raw[:2] == b"\x1f\x8b":
            raw = gzip.decompress(raw)
        data = json.loads(raw.decode())
    except (OSError, EOFError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise MomaError(f"{path}: cannot read JSON ({exc})") from None
    if not isinstance(data, dict):
        raise MomaError(f"{path}: expected a JSON object")
    return data


def dumps_strict(obj: Any, *, null_non_finite: bool = False, **kwargs: Any) -> str:
    """``json.dumps(obj, **kwargs)`` that never writes NaN or infinity, which are not JSON
    (Python writes them as ``NaN`` / ``Infinity``; strict readers reject the file).

    With ``null_non_finite`` they become null: for documents where a missing value is
    legitimate (a distance to nothing). Otherwise MomaError names the first one's place
    (``records[3].target_range``), before anything is written.
    """
    if null_non_finite:
        obj = _null_non_finite(obj)
    try:
        return json.dumps(obj, allow_nan=False, **kwargs)
    except ValueError as exc:
        # json stops at the first bad value, in the order the walk below takes
        where = _first_non_finite(obj, "") if "Out of range float" in str(exc) else None
        if where is None:  # another error (a circular reference): json's own message
            raise
        raise MomaError(
            f"cannot write JSON: {where[0] or 'the value'} is {where[1]}, which JSON cannot "
            "hold (NaN or infinity)"
        ) from None


def _is_non_finite(value: Any) -> bool:
    # numbers.Real includes numpy's floats (written through ``default=float``)
    return (
        isinstance(value, numbers.Real)
        and not isinstance(value, numbers.Integral)
        and not math.isfinite(value)
    )


def _null_non_finite(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {k: _null_non_finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_null_non_finite(v) for v in obj]
    return None if _is_non_finite(obj) else obj


def _first_non_finite(obj: Any, path: str) -> tuple[str, float] | None:
    """The place (``a.b[2]``) and value of the first non-finite number in ``obj``."""
    if isinstance(obj, dict):
        items: Any = ((f"{path}.{k}" if path else str(k), v) for k, v in obj.items())
    elif isinstance(obj, (list, tuple)):
        items = ((f"{path}[{i}]", v) for i, v in enumerate(obj))
    else:
        return (path, float(obj)) if _is_non_finite(obj) else None
    for where, value in items:
        found = _first_non_finite(value, where)
        if found is not None:
            return found
    return None
