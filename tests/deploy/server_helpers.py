"""Helpers of the server tests: ``momakitchen serve``'s aiohttp server in this process
(its loop in a thread), multipart forms of small frames, and a stdlib HTTP client."""

from __future__ import annotations

import asyncio
import io
import json
import threading
import urllib.error
import urllib.request
import uuid
from contextlib import contextmanager

import numpy as np

from momakitchen.deploy import server as srv

H, W = 6, 8
CAMERA = " ".join(["1", "0", "0", "0", "0", "1", "0", "0", "0", "0", "1", "0", "0", "0", "0", "1"])


@contextmanager
def running(server: srv.ModelServer):
    """``server`` listening on a free port of 127.0.0.1, its loop in a thread."""
    loop = asyncio.new_event_loop()
    started = threading.Event()
    where: dict = {}

    def main() -> None:
        asyncio.set_event_loop(loop)
        runner = loop.run_until_complete(server.start("127.0.0.1", 0))
        where["port"] = runner.addresses[0][1]
        started.set()
        loop.run_forever()
        loop.run_until_complete(runner.cleanup())
        loop.close()

    thread = threading.Thread(target=main, daemon=True)
    thread.start()
    assert started.wait(10)
    try:
        yield "127.0.0.1", where["port"]
    finally:
        loop.call_soon_threadsafe(loop.stop)
        thread.join(10)


def npy(array: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.save(buf, array, allow_pickle=True)
    return buf.getvalue()


def png(array: np.ndarray) -> bytes:
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(array).save(buf, format="PNG")
    return buf.getvalue()


def multipart(text: dict, files: dict) -> tuple[bytes, str]:
    """A ``multipart/form-data`` body and its content type: ``text`` fields, then
    ``files`` (bytes, or lists of bytes for a repeated field)."""
    boundary = uuid.uuid4().hex
    body = io.BytesIO()
    items = [(k, v, None) for k, v in text.items()]
    for name, value in files.items():
        for i, data in enumerate(value if isinstance(value, list) else [value]):
            items.append((name, data, f"{name}{i}.bin"))
    for name, value, filename in items:
        disp = f'form-data; name="{name}"' + (f'; filename="{filename}"' if filename else "")
        body.write(f"--{boundary}\r\nContent-Disposition: {disp}\r\n\r\n".encode())
        body.write(value if isinstance(value, bytes) else str(value).encode())
        body.write(b"\r\n")
    body.write(f"--{boundary}--\r\n".encode())
    return body.getvalue(), f"multipart/form-data; boundary={boundary}"


def form(who: str = "r", files: dict | None = None, **fields: str) -> tuple[bytes, str]:
    """A valid small request (an 8x6 frame) with ``files`` and ``fields`` replaced."""
    parts: dict = {
        "depth": npy(np.ones((H, W), np.float32)),
        "target_mask": npy(np.ones((H, W), np.uint8)),
        **(files or {}),
    }
    text = {"intrinsics": "4 4 4 3", "camera_to_base": CAMERA, "robot": who, **fields}
    return multipart(text, parts)


def post(addr, body: bytes, ctype: str, headers: dict | None = None, path: str = "/predict"):
    """(status, JSON answer, headers)."""
    req = urllib.request.Request(
        f"http://{addr[0]}:{addr[1]}{path}",
        data=body,
        headers={"Content-Type": ctype, **(headers or {})},
        method="POST",
    )
    try:
        with urllib.request.urlopen(req, timeout=30) as r:
            return r.status, json.loads(r.read()), dict(r.headers)
    except urllib.error.HTTPError as e:
        return e.code, json.loads(e.read()), dict(e.headers)


def get(addr, path: str, headers: dict | None = None):
    req = urllib.request.Request(f"http://{addr[0]}:{addr[1]}{path}", headers=headers or {})
    try:
        with urllib.request.urlopen(req, timeout=30) as r:
            return r.status, json.loads(r.read()), dict(r.headers)
    except urllib.error.HTTPError as e:
        return e.code, json.loads(e.read()), dict(e.headers)
