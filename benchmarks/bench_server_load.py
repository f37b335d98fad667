"""Benchmark ``momakitchen serve`` under load on 127.0.0.1 with the bundled model (about a
minute a run).

Usage::

    nice -n 10 python benchmarks/bench_server_load.py [--data DIR] [--runs 3]

The frame is the first view of the first scene of ``--data`` (default: a one-scene dataset,
scene 3, generated into a temporary folder, a few seconds). Each run starts the server in
its own process with small limits (``--queue 6 --max-body-mb 16 --max-inflight-mb 64
--read-timeout 3``) and samples its resident memory from ``/proc`` throughout. Four phases:
twelve concurrent 13 MB requests (a 640x480 frame as ``.npy`` with three obstacle masks):
no more than 64 MB of them in flight (five), the rest 503 with Retry-After, memory bounded;
ten concurrent frames of 64 MC-dropout passes: one predicted and six waiting, the rest 503
with Retry-After; clients trickling their headers or body: cut off after the read timeout;
clients resetting their connections mid-body: no traceback. Prints each run's figures and
the limits each phase is expected to hold; exits with status 1 if one did not hold.
BENCHMARKS.md "Serve under load" records the figures.
"""

from __future__ import annotations

import argparse
import io
import json
import os
import re
import socket
import statistics
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
import uuid
from collections.abc import Callable
from pathlib import Path

import numpy as np
from bench_predict import OBSTACLE, TARGET  # run from benchmarks/
from bench_server import one_view
from PIL import Image

LIMITS = ("--queue", "6", "--max-body-mb", "16", "--max-inflight-mb", "64", "--read-timeout", "3")
MB = 1024 * 1024
# The bodies held are at most the 64 MB cap (plus a copy being decoded) over the idle
# server's memory, which includes a frame's working set.
PEAK_OVER_IDLE_MB = 64 + 2 * 16 + 100


def rss_mb(pid: int) -> float:
    """The resident memory of process ``pid`` now (MB), from /proc."""
    text = Path(f"/proc/{pid}/status").read_text()
    match = re.search(r"VmRSS:\s+(\d+) kB", text)
    assert match, text
    return int(match.group(1)) / 1024


class Sampler:
    """The peak of ``rss_mb(pid)`` sampled every 10 ms while it runs."""

    def __init__(self, pid: int) -> None:
        self.pid, self.peak, self._stop = pid, 0.0, threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _run(self) -> None:
        while not self._stop.is_set():
            self.peak = max(self.peak, rss_mb(self.pid))
            time.sleep(0.01)

    def __enter__(self) -> Sampler:
        self._thread.start()
        return self

    def __exit__(self, *_: object) -> None:
        self._stop.set()
        self._thread.join(5)


def npy(array: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.save(buf, array)
    return buf.getvalue()


def png(array: np.ndarray) -> bytes:
    buf = io.BytesIO()
    Image.fromarray(array).save(buf, format="PNG")
    return buf.getvalue()


def multipart(text: dict, files: dict) -> tuple[bytes, str]:
    """A ``multipart/form-data`` body and its content type: ``text`` fields, then ``files``
    (bytes, or lists of bytes for a repeated field)."""
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


def fields(ep, mc: int) -> dict:
    return {
        "intrinsics": " ".join(repr(float(v)) for v in ep.intrinsics),
        "camera_to_base": " ".join(repr(float(v)) for v in ep.camera_to_base.ravel()),
        "robot": ep.robot,
        "mc_samples": str(mc),
        "floor_points": "0",
    }


def large(ep) -> tuple[bytes, str]:
    """A 640x480 frame as 13 MB of .npy: float64 depth, int64 masks (three obstacles)."""
    files = {
        "depth": npy(ep.depth.astype(np.float64)),
        "rgb": npy(ep.rgb),
        "target_mask": npy((ep.semantic == TARGET).astype(np.int64)),
        "obstacle_mask": [npy((ep.semantic == OBSTACLE).astype(np.int64))] * 3,
    }
    return multipart(fields(ep, 8), files)


def small(ep, mc: int) -> tuple[bytes, str]:
    """The same frame as PNGs: 16-bit depth in mm and the target mask."""
    files = {
        "depth": png(np.round(ep.depth * 1000).astype(np.uint16)),
        "target_mask": png((ep.semantic == TARGET).astype(np.uint8) * 255),
    }
    return multipart(fields(ep, mc), files)


def post(addr, body: bytes, ctype: str) -> tuple[int, dict, dict, float]:
    """(status, JSON answer, headers, seconds)."""
    req = urllib.request.Request(
        f"http://{addr[0]}:{addr[1]}/predict", data=body, headers={"Content-Type": ctype}
    )
    t0 = time.perf_counter()
    try:
        with urllib.request.urlopen(req, timeout=120) as r:
            return r.status, json.loads(r.read()), dict(r.headers), time.perf_counter() - t0
    except urllib.error.HTTPError as e:
        return e.code, json.loads(e.read()), dict(e.headers), time.perf_counter() - t0


def at_once(n: int, job: Callable[[int], object]) -> list:
    out: list = [None] * n
    threads = [threading.Thread(target=lambda i=i: out.__setitem__(i, job(i))) for i in range(n)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(300)
    return out


def until_closed(sock: socket.socket, limit: float) -> tuple[bytes, float]:
    t0 = time.monotonic()
    sock.settimeout(limit)
    data = b""
    try:
        while chunk := sock.recv(65536):
            data += chunk
    except ConnectionResetError:
        pass
    except TimeoutError:
        return data, float("inf")
    return data, time.monotonic() - t0


def start_server() -> tuple[subprocess.Popen, tuple[str, int]]:
    """``momakitchen serve --port 0`` with LIMITS in its own process, without a token."""
    code = "import sys; from momakitchen.cli.main import main; sys.exit(main())"
    env = {k: v for k, v in os.environ.items() if k != "MOMAKITCHEN_SERVE_TOKEN"}
    argv = [sys.executable, "-c", code, "serve", "--port", "0", *LIMITS]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    line: list[bytes] = []
    assert proc.stdout is not None and proc.stderr is not None
    reader = threading.Thread(target=lambda: line.append(proc.stdout.readline()), daemon=True)
    reader.start()
    reader.join(90)
    match = re.search(rb"http://127\.0\.0\.1:(\d+)", line[0] if line else b"")
    if not match:
        proc.kill()
        sys.exit(f"the server did not start: {line} {proc.stderr.read()!r}")
    return proc, ("127.0.0.1", int(match.group(1)))


def trickle(addr, head: bytes, chunks: list[bytes]) -> tuple[bytes, float]:
    """Send ``head``, then one of ``chunks`` every 0.2 s until the server closes; (what it
    answered, seconds from the first chunk to the close)."""
    s = socket.create_connection(addr)
    s.sendall(head)
    t0 = time.monotonic()
    try:
        for chunk in chunks:
            s.sendall(chunk)
            time.sleep(0.2)
    except (BrokenPipeError, ConnectionResetError):
        pass
    data, _ = until_closed(s, 10)
    cut = time.monotonic() - t0
    s.close()
    return data, cut


def one_run(ep, failures: list[str]) -> None:
    """The four phases against a fresh server; prints the figures, appends to ``failures``
    each expected limit that did not hold."""

    def expect(ok: bool, what: str) -> None:
        if not ok:
            failures.append(what)
            print(f"  NOT HELD: {what}", flush=True)

    proc, addr = start_server()
    try:
        print(f"machine: {os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}", flush=True)
        body, ctype = large(ep)
        for _ in range(2):  # warm-up: the model's first frames allocate what it keeps
            expect(post(addr, body, ctype)[0] == 200, "warm-up frame answered")
        idle = rss_mb(proc.pid)

        # 1. twelve 13 MB requests at once
        with Sampler(proc.pid) as mem:
            answers = at_once(12, lambda i: post(addr, body, ctype))
        codes = [a[0] for a in answers]
        busy = [a for a in answers if a[0] == 503]
        ok = [a[3] for a in answers if a[0] == 200] or [float("nan")]
        print(
            f"12 x {len(body) / MB:.1f} MB at once: {codes.count(200)} answered (median "
            f"{statistics.median(ok):.2f} s), {len(busy)} 503; memory idle {idle:.0f} MB, "
            f"peak {mem.peak:.0f} MB (+{mem.peak - idle:.0f} MB)",
            flush=True,
        )
        expect(set(codes) <= {200, 503} and codes.count(200) >= 5, f"200 or 503, >= 5 200: {codes}")
        expect(
            bool(busy) and all("64 MB of requests are in flight" in a[1]["error"] for a in busy),
            "the bodies over 64 MB refused for the in-flight limit",
        )
        expect(all(int(a[2]["Retry-After"]) >= 1 for a in busy), "Retry-After >= 1 s")
        expect(mem.peak - idle < PEAK_OVER_IDLE_MB, f"peak under +{PEAK_OVER_IDLE_MB} MB")

        # 2. the queue: ten frames of 64 MC-dropout passes at once
        body2, ctype2 = small(ep, 64)
        answers = at_once(10, lambda i: post(addr, body2, ctype2))
        codes = [a[0] for a in answers]
        busy = [a for a in answers if a[0] == 503]
        retry = [int(a[2]["Retry-After"]) for a in busy] or [0]
        done = [float(a[2]["X-Predict-Seconds"]) for a in answers if a[0] == 200]
        print(
            f"10 x mc_samples=64 at once: {codes.count(200)} answered, {len(busy)} 503 "
            f"(Retry-After {min(retry)}-{max(retry)} s); model "
            f"{statistics.median(done or [float('nan')]):.2f} s a frame",
            flush=True,
        )
        # one predicted and six waiting; more when the first are done before the last arrive
        expect(set(codes) <= {200, 503} and codes.count(200) >= 7, f">= 7 answered: {codes}")
        expect(
            bool(busy)
            and all("the model's queue is full: 6 waiting" in a[1]["error"] for a in busy),
            "the rest refused for the full queue",
        )
        expect(min(retry) >= 1, "Retry-After >= 1 s")

        # 3. slow clients
        head_data, head_cut = trickle(addr, b"POST /predict HTTP/1.1\r\nHost: x\r\n", [b"X"] * 50)
        head = (
            f"POST /predict HTTP/1.1\r\nHost: x\r\nContent-Type: {ctype}\r\n"
            f"Content-Length: {len(body)}\r\n\r\n"
        ).encode()
        body_data, body_cut = trickle(
            addr, head, [body[i * 100 : (i + 1) * 100] for i in range(50)]
        )
        print(
            f"trickled headers cut after {head_cut:.1f} s, trickled body "
            f"({body_data[9:12].decode(errors='replace')}) after {body_cut:.1f} s",
            flush=True,
        )
        expect(head_data == b"" and head_cut < 3 + 1.5, "trickled headers closed, no answer")
        expect(body_data.startswith(b"HTTP/1.1 408") and body_cut < 3 + 1.5, "trickled body: 408")

        # 4. clients that reset mid-body while frames are predicted
        def reset(i: int) -> None:
            r = socket.create_connection(addr)
            r.sendall(head + body[: 1 + i * MB])
            r.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, b"\x01" + bytes(7))
            r.close()

        at_once(6, lambda i: reset(i) if i % 2 else post(addr, body2, ctype2))
        expect(post(addr, *small(ep, 0))[0] == 200, "a frame answered after the resets")
        # the reservations of the clients that left are released: five bodies fit again
        codes = [a[0] for a in at_once(5, lambda i: post(addr, body, ctype))]
        expect(codes == [200] * 5, f"five full-size bodies fit again: {codes}")
        print(f"memory at the end: {rss_mb(proc.pid):.0f} MB", flush=True)
    finally:
        proc.terminate()
        _, err = proc.communicate(timeout=15)
    expect(b"Traceback" not in err, "no traceback on the server's stderr")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=None, help="dataset directory (momakitchen generate)")
    ap.add_argument("--runs", type=int, default=1, help="runs, each against a fresh server")
    args = ap.parse_args(argv)
    ep = one_view(args.data, view=0)
    failures: list[str] = []
    for k in range(args.runs):
        print(f"run {k + 1} of {args.runs}", flush=True)
        one_run(ep, failures)
    if failures:
        print(f"{len(failures)} expected limits did not hold", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
