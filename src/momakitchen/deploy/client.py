"""A client of ``momakitchen serve``'s HTTP API: a method that runs elsewhere, asked at
every look (``momakitchen approach --server URL``; the API is in docs/METHODS.md).

:class:`ServerPerceiver` checks ``GET /health`` when it is made (an unreachable server is
an error before any work), then posts each frame to ``POST /predict`` as
``multipart/form-data`` (depth, masks and colour as ``.npy``) and turns the answer back
into a :class:`~momakitchen.models.inference.Prediction`. An answer that is not the
documented ``prediction.json`` (bad JSON, missing or non-finite fields, affordance outside
[0, 1]), a 5xx, a refused token or a timeout is a fatal error naming the server: the run
stops and keeps what it has done. A 4xx for a frame is a failed look; a 503 (the server's
queue is full) is waited out as its ``Retry-After`` asks, up to five times.
Standard library only (``urllib``).
"""

from __future__ import annotations

import io
import json
import os
import time
import urllib.error
import urllib.request
import uuid
from typing import Any

import numpy as np

from momakitchen.errors import MomaError

TOKEN_ENV = "MOMAKITCHEN_SERVE_TOKEN"
BUSY_RETRIES = 5  # 503 answers (a full queue) waited out before giving up


def _retry_after(value: str | None) -> float:
    """Seconds to wait from a Retry-After header (1 s when absent or a date), at most 30."""
    try:
        return min(max(float(value or 1), 0.0), 30.0)
    except ValueError:
        return 1.0


class ServerError(MomaError):
    """The server is unreachable or answered something that is not a prediction: the
    method cannot be scored, so the run stops (not a failed look)."""

    fatal = True


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
    """A registered name as ``robot``; a descriptor (a drawn mount height) as the numbers
    the API takes: reach, mount height, joints, suction, a gripper's finger force and
    where the shoulder stands."""
    if isinstance(robot, str):
        return [("robot", robot)]
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


class ServerPerceiver:
    """A model behind ``momakitchen serve`` at ``url`` (e.g. ``http://127.0.0.1:8000``)."""

    def __init__(self, url: str, timeout: float = 60.0, token: str | None = None) -> None:
        if not url.startswith(("http://", "https://")):
            raise MomaError(f"--server must be an http:// or https:// URL, got {url!r}")
        self.url = url.rstrip("/")
        self.timeout = timeout
        self.token = token if token is not None else os.environ.get(TOKEN_ENV)
        health = self._request("/health", None, None, 10.0)
        if not isinstance(health, dict) or "model" not in health:
            raise ServerError(f"server {self.url!r}: /health is not momakitchen serve's answer")
        self.name = f"server:{health['model']}"

    def _request(self, path: str, body: bytes | None, ctype: str | None, timeout: float) -> Any:
        req = urllib.request.Request(self.url + path, data=body, method="POST" if body else "GET")
        if ctype:
            req.add_header("Content-Type", ctype)
        if self.token:
            req.add_header("Authorization", f"Bearer {self.token}")
        for attempt in range(BUSY_RETRIES + 1):
            try:
                with urllib.request.urlopen(req, timeout=timeout) as resp:
                    raw = resp.read()
                break
            except urllib.error.HTTPError as exc:
                if exc.code == 503 and attempt < BUSY_RETRIES:
                    # Busy (its queue is full): wait as it asks, then try again.
                    time.sleep(_retry_after(exc.headers.get("Retry-After")))
                    continue
                raise self._refusal(exc, path) from None
            except (urllib.error.URLError, OSError, TimeoutError) as exc:
                reason = getattr(exc, "reason", exc)
                raise ServerError(f"cannot reach server {self.url!r}{path}: {reason}") from None
        try:
            return json.loads(raw)
        except (json.JSONDecodeError, UnicodeDecodeError):
            raise ServerError(
                f"server {self.url!r}{path} answered something that is not JSON"
            ) from None

    def _refusal(self, exc: urllib.error.HTTPError, path: str) -> MomaError:
        """A refused frame (4xx but authentication: a failed look), else a fatal error."""
        detail = exc.read()[:300].decode("utf-8", "replace")
        if 400 <= exc.code < 500 and exc.code not in (401, 403) and path == "/predict":
            return MomaError(f"server {self.url!r} refused the frame: {detail}")
        return ServerError(f"server {self.url!r}{path} answered HTTP {exc.code}: {detail}")

    def __call__(self, frame: Any, robot: Any, metric: bool, config: Any) -> Any:
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
        fields += [("obstacle_mask", _npy(m.astype(np.uint8))) for m in frame.obstacle_masks]
        body, ctype = multipart(fields)
        return self.parse(self._request("/predict", body, ctype, self.timeout), robot)

    def parse(self, doc: Any, robot: Any) -> Any:
        """A :class:`Prediction` from a ``prediction.json`` document; ServerError if it is
        not one."""
        from momakitchen.models.inference import Prediction

        def bad(what: str) -> ServerError:
            return ServerError(f"server {self.url!r} answered a malformed prediction: {what}")

        try:
            rows = np.asarray(doc["floor_points"]["rows"], np.float64).reshape(-1, 5)
            target = np.asarray(doc["target_xyz"], np.float64).reshape(3)
            poses = doc["poses"]
            pose_rows = np.asarray(
                [[q["x"], q["y"], q["yaw"], q["affordance"], q["uncertainty"]] for q in poses],
                np.float64,
            ).reshape(-1, 5)
        except (KeyError, TypeError, ValueError) as exc:
            raise bad(f"{type(exc).__name__}: {exc}") from None
        if not (
            np.isfinite(rows).all() and np.isfinite(target).all() and np.isfinite(pose_rows).all()
        ):
            raise bad("non-finite numbers")
        if len(rows) and not ((rows[:, 3] >= 0) & (rows[:, 3] <= 1)).all():
            raise bad("affordance outside [0, 1]")
        return Prediction(
            floor_xyz=rows[:, :3],
            affordance=rows[:, 3],
            uncertainty=rows[:, 4],
            poses=pose_rows[:, :3],
            pose_scores=pose_rows[:, 3],
            pose_uncertainty=pose_rows[:, 4],
            target_xyz=target,
            robot=robot if isinstance(robot, str) else "custom",
            model=str(doc.get("model", self.name)),
        )
