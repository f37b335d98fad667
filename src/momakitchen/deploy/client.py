"""A client of ``momakitchen serve``'s HTTP API: a method that runs elsewhere, asked at
every look (``momakitchen approach --server URL``; the API is in docs/METHODS.md).

:class:`ServerPerceiver` checks the URL and ``GET /health`` when it is made (a malformed
URL or an unreachable server is an error before any work), then posts each frame to
``POST /predict`` as ``multipart/form-data`` (depth, masks and colour as ``.npy``) and
turns the answer back into a :class:`~momakitchen.models.inference.Prediction`.

Every answer is untrusted (:class:`ClientLimits`): each request has one deadline, from
connecting to its last byte, and the bytes read are capped while they arrive, so a server
that drips or floods its answer is cut off; a malformed HTTP answer, a redirect (never
followed: the token and the frame go to the configured server only), JSON that is not the
documented ``prediction.json`` (numbers that are strings, non-finite, affordance outside
[0, 1], negative uncertainty), a 5xx or a refused token is a fatal :class:`ServerError`
naming the server and the problem: the run stops and keeps what it has done. A 4xx for a
frame is a failed look; a 503 (the server's queue is full) is waited out as its
``Retry-After`` asks, up to ``busy_retries`` times. Standard library only (``http.client``).
"""

from __future__ import annotations

import http.client
import io
import json
import math
import os
import socket
import time
import urllib.parse
import uuid
from dataclasses import dataclass
from typing import Any

import numpy as np

from momakitchen.errors import MomaError

TOKEN_ENV = "MOMAKITCHEN_SERVE_TOKEN"
COLUMNS = ["x", "y", "z", "affordance", "uncertainty"]
POSE_KEYS = ("x", "y", "yaw", "affordance", "uncertainty")
MAX_INT_DIGITS = 30  # a prediction's numbers are floats; longer integers are refused unparsed


@dataclass(frozen=True)
class ClientLimits:
    """What the client waits for and reads from a server (docs/METHODS.md, section 3).

    ``timeout``: seconds one ``/predict`` request may take in all, from connecting to the
    answer's last byte (a server that sends a byte now and then does not reset it);
    ``health_timeout``: the same for ``/health``; ``max_answer_bytes``: the most bytes
    one answer may be, status line and headers included, counted while they arrive (a
    larger one is cut off, never read whole); ``busy_retries``: 503 answers (a full
    queue) waited out before giving up. MomaError names a bad value.
    """

    timeout: float = 60.0
    health_timeout: float = 10.0
    max_answer_bytes: int = 32 * 1024 * 1024  # a 640x480 frame's floor points are < 1 MB
    busy_retries: int = 5

    def __post_init__(self) -> None:
        for name in ("timeout", "health_timeout"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise MomaError(f"the client's {name} must be a number of seconds, got {value!r}")
            if not (math.isfinite(value) and 0 < value <= 3600):
                raise MomaError(f"the client's {name} must be in (0, 3600] s, got {value!r}")
        cap = self.max_answer_bytes
        if isinstance(cap, bool) or not isinstance(cap, int) or not 1024 <= cap <= 2**30:
            raise MomaError(
                f"the client's max_answer_bytes must be an integer in [1024, 2**30], got {cap!r}"
            )
        retries = self.busy_retries
        if isinstance(retries, bool) or not isinstance(retries, int) or not 0 <= retries <= 100:
            raise MomaError(
                f"the client's busy_retries must be an integer in [0, 100], got {retries!r}"
            )


def _retry_after(value: str | None) -> float:
    """Seconds to wait from a Retry-After header (1 s when absent or a date), at most 30."""
    try:
        wait = float(value or 1)
    except ValueError:
        return 1.0
    return min(max(wait, 0.0), 30.0) if math.isfinite(wait) else 1.0


class ServerError(MomaError):
    """The server is unreachable or answered something that is not a prediction: the
    method cannot be scored, so the run stops (not a failed look)."""

    fatal = True


def _show(value: Any, width: int = 60) -> str:
    """``value`` for a one-line message: its repr, shortened."""
    text = repr(value)
    return text if len(text) <= width else text[: width - 3] + "..."


def server_url(url: str) -> tuple[str, str, int, str]:
    """Scheme, host, port and path prefix of ``--server URL``; MomaError names a URL
    that is not ``http(s)://HOST[:PORT][/PREFIX]``."""
    if not isinstance(url, str) or not url.startswith(("http://", "https://")):
        raise MomaError(f"--server must be an http:// or https:// URL, got {_show(url)}")
    if any(c <= " " or c == "\x7f" for c in url):
        raise MomaError(f"--server URL must not hold spaces or control characters: {_show(url)}")
    try:
        parts = urllib.parse.urlsplit(url)
        port = parts.port
    except ValueError as exc:  # "http://[::1", a port that is not a number or > 65535
        raise MomaError(f"--server URL {_show(url)} is malformed: {exc}") from None
    if not parts.hostname:
        raise MomaError(f"--server URL {_show(url)} names no host")
    if parts.username is not None or parts.password is not None:
        shown = urllib.parse.urlunsplit(parts._replace(netloc="***@" + parts.netloc.split("@")[-1]))
        raise MomaError(  # not shown: a password is a secret
            f"--server URL {_show(shown)} holds a user name or password: give the token in "
            f"{TOKEN_ENV} instead"
        )
    if parts.query or parts.fragment or url.endswith(("?", "#")):
        raise MomaError(f"--server URL {_show(url)} has a query or fragment: give only the base")
    if port == 0:
        raise MomaError(f"--server URL {_show(url)} has port 0")
    default = 443 if parts.scheme == "https" else 80
    return parts.scheme, parts.hostname, port or default, parts.path.rstrip("/")


class _Expired(Exception):
    """The request's deadline passed (not an OSError: http.client must not catch it)."""


class _TooLarge(Exception):
    """The answer passed the byte cap."""


class _Malformed(Exception):
    """The answer's JSON holds something the parser must not build."""


class _BudgetedSocket(io.RawIOBase):
    """A socket's bytes under one request's deadline and byte cap: each read waits at most
    until the deadline, and every byte read (status line and headers too) is counted, so a
    server that drips or floods its answer is cut off while it sends."""

    def __init__(self, sock: socket.socket, deadline: float, cap: int) -> None:
        super().__init__()
        self.sock = sock
        self.deadline = deadline
        self.cap = cap
        self.count = 0

    def readable(self) -> bool:
        return True

    def readinto(self, buf: Any) -> int:
        left = self.deadline - time.monotonic()
        if left <= 0:
            raise _Expired
        self.sock.settimeout(left)
        try:
            n = self.sock.recv_into(buf)
        except TimeoutError:
            raise _Expired from None
        self.count += n
        if self.count > self.cap:
            raise _TooLarge
        return n


class _Response(http.client.HTTPResponse):
    """An HTTP answer read through a :class:`_BudgetedSocket`."""

    def __init__(self, sock: socket.socket, method: str, reader: _BudgetedSocket) -> None:
        super().__init__(sock, method=method)
        self.fp.close()  # the plain file of the socket, unused
        self.fp = io.BufferedReader(reader)


def _parse_int(text: str) -> int:
    # int() of thousands of digits is slow (and refused past 4300): no prediction has one
    if len(text.lstrip("-")) > MAX_INT_DIGITS:
        raise _Malformed(f"an integer of {len(text.lstrip('-'))} digits")
    return int(text)


def _npy(a: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.save(buf, np.ascontiguousarray(a), allow_pickle=False)
    return buf.getvalue()


def multipart(fields: list[tuple[str, str | bytes]]) -> tuple[bytes, str]:
    """A ``multipart/form-data`` body and its content type; bytes values are sent as
    files named after their field."""
    boundary = uuid.uuid4().hex
    out = io.BytesIO()
    for name, value in fields:
        out.write(f"--{boundary}\r\n".encode())
        if isinstance(value, bytes):
            out.write(
                f'Content-Disposition: form-data; name="{name}"; filename="{name}.npy"\r\n'
                "Content-Type: application/octet-stream\r\n\r\n".encode()
            )
            out.write(value)
        else:
            out.write(f'Content-Disposition: form-data; name="{name}"\r\n\r\n{value}'.encode())
        out.write(b"\r\n")
    out.write(f"--{boundary}--\r\n".encode())
    return out.getvalue(), f"multipart/form-data; boundary={boundary}"


def _robot_fields(robot: Any) -> list[tuple[str, str | bytes]]:
    """A registered name as ``robot``; ``(name, mount height)`` as ``robot`` and
    ``mount_height`` (a registered robot at a drawn mount: what a classical method needs of
    it, its URDF); a descriptor as the numbers the API takes: reach, mount height, joints,
    suction, a gripper's finger force and where the shoulder stands."""
    if isinstance(robot, str):
        return [("robot", robot)]
    if isinstance(robot[0], str):  # a registered robot at a drawn mount height
        return [("robot", robot[0]), ("mount_height", f"{float(robot[1]):.6g}")]
    suction = bool(robot[3] >= 0.5)
    fields: list[tuple[str, str | bytes]] = [
        ("reach", f"{robot[0]:.6g}"),
        ("mount_height", f"{robot[1]:.6g}"),
        ("dof", f"{round(robot[2] * 7)}"),
        ("suction", "1" if suction else "0"),
    ]
    if not suction and len(robot) > 4:
        fields.append(("finger_force", f"{robot[4] * 100:.6g}"))
    if len(robot) > 6:  # version 3: the shoulder's height above the floor, offset per 10 cm
        fields.append(("shoulder_rise", f"{robot[5] - robot[1]:.6g}"))
        fields.append(("shoulder_offset", f"{robot[6] / 10:.6g}"))
    return fields


_NUMBER = (int, float)


class ServerPerceiver:
    """A model behind ``momakitchen serve`` at ``url`` (e.g. ``http://127.0.0.1:8000``),
    asked under ``limits`` (:class:`ClientLimits`)."""

    def __init__(
        self, url: str, limits: ClientLimits | None = None, token: str | None = None
    ) -> None:
        self.scheme, self.host, self.port, self.prefix = server_url(url)
        self.url = url.rstrip("/")
        self.limits = limits if limits is not None else ClientLimits()
        if not isinstance(self.limits, ClientLimits):
            raise MomaError(f"limits must be ClientLimits, got {type(self.limits).__name__}")
        self.token = token if token is not None else (os.environ.get(TOKEN_ENV) or None)
        if self.token is not None and not (
            self.token.isascii() and self.token.isprintable() and " " not in self.token
        ):
            # a header carries printable ASCII only; the token itself is a secret, not shown
            raise MomaError(
                f"the server token ({TOKEN_ENV}) must be printable ASCII without spaces"
            )
        health = self._request("/health", None, None, self.limits.health_timeout)
        if not isinstance(health, dict) or not isinstance(health.get("model"), str):
            raise ServerError(
                f"server {self.url!r}: /health is not momakitchen serve's answer (an object "
                f"with a 'model' name), got {_show(health)}"
            )
        self.name = f"server:{health['model'][:100]}"

    # ------------------------------------------------------------------------ HTTP
    def _request(self, path: str, body: bytes | None, ctype: str | None, timeout: float) -> Any:
        """The JSON answer of ``path``: POST ``body`` (GET without one), busy answers waited
        out; ServerError (or MomaError: a refused frame) otherwise."""
        for attempt in range(self.limits.busy_retries + 1):
            status, headers, raw = self._exchange(path, body, ctype, timeout)
            if status == 503 and attempt < self.limits.busy_retries:
                # Busy (its queue is full): wait as it asks, then try again.
                time.sleep(_retry_after(headers.get("Retry-After")))
                continue
            break
        where = f"server {self.url!r}{path}"
        if 300 <= status < 400:
            location = _show(headers.get("Location", ""), 100)
            raise ServerError(
                f"{where} answered a redirect (HTTP {status} to {location}): redirects are "
                "not followed, so that the token and the frame go to the given server only"
            )
        if not 200 <= status < 300:
            detail = " ".join(raw.decode("utf-8", "replace").split())
            if 400 <= status < 500 and status not in (401, 403) and path == "/predict":
                raise MomaError(f"server {self.url!r} refused the frame: {detail}")
            raise ServerError(f"{where} answered HTTP {status}: {detail}")
        try:
            return json.loads(raw, parse_int=_parse_int)
        except _Malformed as exc:
            raise ServerError(f"{where} answered JSON with {exc}") from None
        except RecursionError:
            raise ServerError(f"{where} answered JSON nested too deeply") from None
        except (ValueError, UnicodeDecodeError):
            raise ServerError(f"{where} answered something that is not JSON") from None

    def _exchange(
        self, path: str, body: bytes | None, ctype: str | None, timeout: float
    ) -> tuple[int, http.client.HTTPMessage, bytes]:
        """One request under one deadline: the status, headers and body (of an answer
        that is not a 2xx, its first 300 bytes); ServerError names what went wrong."""
        where = f"server {self.url!r}{path}"
        cap = self.limits.max_answer_bytes
        deadline = time.monotonic() + timeout
        method = "POST" if body is not None else "GET"
        headers = {"Content-Type": ctype} if ctype else {}
        if self.token:
            headers["Authorization"] = f"Bearer {self.token}"
        kind = http.client.HTTPSConnection if self.scheme == "https" else http.client.HTTPConnection
        conn = kind(self.host, self.port, timeout=timeout)
        connected = False
        try:
            conn.connect()
            connected = True
            sock = conn.sock
            # sendall's timeout bounds all of the body, not each send
            sock.settimeout(max(deadline - time.monotonic(), 1e-3))
            conn.request(method, self.prefix + path, body=body, headers=headers)
            resp = _Response(sock, method, _BudgetedSocket(sock, deadline, cap))
            resp.begin()
            if not 200 <= resp.status < 300:
                return resp.status, resp.msg, resp.read(300)
            if resp.length is not None and resp.length > cap:
                raise _TooLarge
            return resp.status, resp.msg, resp.read()
        except (_Expired, TimeoutError):
            raise ServerError(
                f"{where} did not answer within {timeout:g} s (the request deadline)"
            ) from None
        except _TooLarge:
            raise ServerError(
                f"{where} answered more than {cap} bytes (the answer limit)"
            ) from None
        except http.client.RemoteDisconnected:
            raise ServerError(f"{where} closed the connection without answering") from None
        except http.client.BadStatusLine as exc:
            line = _show(exc.args[0] if exc.args else "")
            raise ServerError(f"{where} answered a bad HTTP status line: {line}") from None
        except http.client.LineTooLong as exc:
            raise ServerError(f"{where} answered an HTTP line too long ({exc})") from None
        except http.client.IncompleteRead as exc:
            raise ServerError(
                f"{where} answered a truncated body: {len(exc.partial)} bytes, "
                f"{exc.expected} more announced"
            ) from None
        except http.client.HTTPException as exc:  # e.g. more than 100 headers
            raise ServerError(f"{where} answered a malformed HTTP answer: {exc}") from None
        except OSError as exc:
            what = "lost the connection to" if connected else "cannot reach"
            reason = exc.strerror or exc
            raise ServerError(f"{what} server {self.url!r}{path}: {reason}") from None
        finally:
            conn.close()

    # ---------------------------------------------------------------------- frames
    def __call__(
        self, frame: Any, robot: Any, metric: bool, config: Any, opens: bool = False
    ) -> Any:
        fields: list[tuple[str, str | bytes]] = [
            ("depth", _npy(np.asarray(frame.depth, np.float32))),
            ("target_mask", _npy(frame.target_mask.astype(np.uint8))),
            ("rgb", _npy(np.asarray(frame.rgb, np.uint8))),
            ("intrinsics", " ".join(f"{v:.10g}" for v in frame.intrinsics.as_array())),
            ("camera_to_base", " ".join(f"{v:.12g}" for v in np.ravel(frame.camera_to_base))),
            *_robot_fields(robot),
            ("top_k", "1"),
            ("mc_samples", str(config.mc_samples)),
            ("pick_radius", f"{config.pick_radius:g}"),
        ]
        if opens:  # (a server older than the field answers a pick as before)
            fields.append(("opens", "1"))
        fields += [("obstacle_mask", _npy(m.astype(np.uint8))) for m in frame.obstacle_masks]
        body, ctype = multipart(fields)
        return self.parse(self._request("/predict", body, ctype, self.limits.timeout), robot)

    def parse(self, doc: Any, robot: Any) -> Any:
        """A :class:`Prediction` from a ``prediction.json`` document (the schema of
        docs/METHODS.md, section 3); ServerError names the first field that breaks it."""
        from momakitchen.models.inference import Prediction

        def bad(what: str) -> ServerError:
            return ServerError(f"server {self.url!r} answered a malformed prediction: {what}")

        if not isinstance(doc, dict):
            raise bad(f"not a JSON object: {_show(doc)}")
        for key in ("target_xyz", "floor_points", "poses"):
            if key not in doc:
                raise bad(f"no {key!r}")
        model = doc.get("model", self.name)
        if not isinstance(model, str):
            raise bad(f"'model' must be a string, got {_show(model)}")
        target = _table([doc["target_xyz"]], "target_xyz", 3, bad, single=True)[0]
        floor = doc["floor_points"]
        if not isinstance(floor, dict) or "rows" not in floor:
            raise bad(f"'floor_points' must be an object with 'rows', got {_show(floor)}")
        if floor.get("columns", COLUMNS) != COLUMNS:
            raise bad(f"floor_points.columns must be {COLUMNS}, got {_show(floor['columns'])}")
        rows = _table(floor["rows"], "floor_points.rows", 5, bad)
        poses = doc["poses"]
        if not isinstance(poses, list):
            raise bad(f"'poses' must be a list, got {_show(poses)}")
        for i, pose in enumerate(poses):
            if not isinstance(pose, dict) or any(k not in pose for k in POSE_KEYS):
                raise bad(f"poses[{i}] must be an object with {', '.join(POSE_KEYS)}")
        pose_rows = _table(
            [[q[k] for k in POSE_KEYS] for q in poses], "poses", 5, bad, names=POSE_KEYS
        )
        return Prediction(
            floor_xyz=rows[:, :3],
            affordance=rows[:, 3],
            uncertainty=rows[:, 4],
            poses=pose_rows[:, :3],
            pose_scores=pose_rows[:, 3],
            pose_uncertainty=pose_rows[:, 4],
            target_xyz=target,
            robot=robot
            if isinstance(robot, str)
            else str(robot[0])
            if isinstance(robot[0], str)
            else "custom",
            model=model,
        )


def _table(
    rows: Any,
    field: str,
    width: int,
    bad: Any,
    names: tuple[str, ...] | None = None,
    single: bool = False,
) -> np.ndarray:
    """``rows`` (a list of lists of ``width`` JSON numbers) as an (N, width) float array,
    checked: finite, affordance (column 3 of 5) in [0, 1], uncertainty (column 4) >= 0.
    ``bad(message)`` is the error naming the first field that breaks it (``field[i][j]``,
    ``field[i].name`` with ``names``, ``field[j]`` when ``single``)."""

    def at(i: int, j: int) -> str:
        if single:
            return f"{field}[{j}]"
        return f"{field}[{i}].{names[j]}" if names else f"{field}[{i}][{j}]"

    if not isinstance(rows, list):
        raise bad(f"{field} must be a list, got {_show(rows)}")
    for i, row in enumerate(rows):
        if not isinstance(row, list) or len(row) != width:
            where = field if single else f"{field}[{i}]"
            raise bad(f"{where} must be a list of {width} numbers, got {_show(row)}")
        for j, value in enumerate(row):
            # JSON numbers only: "0.5" (a string) and true (a bool) are not numbers
            if type(value) not in _NUMBER:
                raise bad(f"{at(i, j)} must be a JSON number, got {_show(value)}")
    table = np.array(rows, np.float64).reshape(-1, width)
    checks = [(~np.isfinite(table), "non-finite")]
    if width == 5:
        aff, unc = table[:, 3:4], table[:, 4:5]
        pad = np.zeros((len(table), 3), bool)
        with np.errstate(invalid="ignore"):
            checks.append((np.hstack([pad, (aff < 0) | (aff > 1), pad[:, :1]]), "outside [0, 1]"))
            checks.append((np.hstack([pad, pad[:, :1], unc < 0]), "negative"))
    for wrong, why in checks:
        if wrong.any():
            i, j = (int(v) for v in np.argwhere(wrong)[0])
            raise bad(f"{at(i, j)} = {_show(rows[i][j])} is {why}")
    return table
