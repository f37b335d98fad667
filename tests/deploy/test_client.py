"""The client of serve's API that the approach track calls: busy servers, refused
frames and answers that are not predictions."""

from __future__ import annotations

import json
import socket
import threading
import time
import tracemalloc
from contextlib import contextmanager
from http.server import BaseHTTPRequestHandler, HTTPServer
from types import SimpleNamespace

import numpy as np
import pytest

from momakitchen.deploy import client as client_module
from momakitchen.deploy.client import ClientLimits, ServerError, ServerPerceiver
from momakitchen.errors import MomaError
from momakitchen.perception.camera import Intrinsics

GOOD = {
    "target_xyz": [2.0, 0.1, 0.8],
    "floor_points": {
        "columns": ["x", "y", "z", "affordance", "uncertainty"],
        "rows": [[1.0, 0.0, 0.0, 0.7, 0.05], [1.2, 0.1, 0.0, 0.2, 0.01]],
    },
    "poses": [{"x": 1.0, "y": 0.0, "yaw": 0.1, "affordance": 0.7, "uncertainty": 0.05}],
}


def _serve(answers):
    """A server whose /predict gives ``answers`` in turn: (status, body bytes)."""
    seen = []

    class Handler(BaseHTTPRequestHandler):
        def do_GET(self):
            self._send(200, json.dumps({"model": "mine"}).encode())

        def do_POST(self):
            seen.append(self.rfile.read(int(self.headers["Content-Length"])))
            self._send(*answers[min(len(seen), len(answers)) - 1])

        def _send(self, status, body):
            self.send_response(status)
            if status == 503:
                self.send_header("Retry-After", "0")
            self.end_headers()
            self.wfile.write(body)

        def log_message(self, *args):
            pass

    httpd = HTTPServer(("127.0.0.1", 0), Handler)
    threading.Thread(target=httpd.serve_forever, daemon=True).start()
    return httpd, f"http://127.0.0.1:{httpd.server_address[1]}", seen


def _frame():
    h, w = 6, 8
    return SimpleNamespace(
        depth=np.full((h, w), 2.0, np.float32),
        target_mask=np.ones((h, w), bool),
        obstacle_masks=(np.zeros((h, w), bool),),
        rgb=np.zeros((h, w, 3), np.uint8),
        intrinsics=Intrinsics(5.0, 5.0, 4.0, 3.0, w, h),
        camera_to_base=np.eye(4),
    )


CONFIG = SimpleNamespace(mc_samples=0, pick_radius=0.0)


def test_a_busy_server_is_waited_out_and_its_answer_parsed():
    httpd, url, seen = _serve([(503, b"busy"), (200, json.dumps(GOOD).encode())])
    try:
        server = ServerPerceiver(url)
        pred = server(_frame(), "panda", True, CONFIG)
    finally:
        httpd.shutdown()
    assert server.name == "server:mine" and len(seen) == 2
    assert b'name="robot"\r\n\r\npanda' in seen[0]
    np.testing.assert_allclose(pred.affordance, [0.7, 0.2])
    np.testing.assert_allclose(pred.target_xyz, [2.0, 0.1, 0.8])


@pytest.mark.parametrize(
    ("status", "body", "error", "message"),
    [
        (422, b'{"error": "the target mask is empty"}', MomaError, "refused the frame"),
        (401, b'{"error": "token"}', ServerError, "HTTP 401"),
        (500, b"boom", ServerError, "HTTP 500"),
        (200, b"<html>", ServerError, "not JSON"),
        (200, json.dumps({**GOOD, "target_xyz": [1, 2]}).encode(), ServerError, "malformed"),
        (200, json.dumps(GOOD).replace("0.7", "NaN").encode(), ServerError, "non-finite"),
        (200, json.dumps(GOOD).replace("0.7", "1.5").encode(), ServerError, "outside"),
    ],
)
def test_answers_that_are_not_predictions(status, body, error, message):
    httpd, url, _ = _serve([(status, body)])
    try:
        with pytest.raises(error, match=message) as info:
            ServerPerceiver(url)(_frame(), "panda", True, CONFIG)
    finally:
        httpd.shutdown()
    # Only a refused frame is a failed look; the rest stop the run.
    assert getattr(info.value, "fatal", False) == (error is ServerError)


def test_no_server_is_an_error_before_any_work():
    with pytest.raises(ServerError, match="cannot reach server"):
        ServerPerceiver("http://127.0.0.1:9")
    with pytest.raises(MomaError, match="http:// or https://"):
        ServerPerceiver("127.0.0.1:8000")


# ------------------------------------------------------------------ hostile servers
HEALTH = json.dumps({"model": "mine"}).encode()


def _http(body: bytes, status: str = "200 OK", headers: str = "") -> bytes:
    return (
        f"HTTP/1.1 {status}\r\nContent-Length: {len(body)}\r\nConnection: close\r\n{headers}\r\n"
    ).encode() + body


@contextmanager
def _raw_server(answer):
    """A socket server on a free port of 127.0.0.1 that reads each request (head and
    body) and answers it with ``answer(path, conn)``, raw bytes written to the socket;
    yields its URL and the (method, path, headers) of the requests it got."""
    listener = socket.create_server(("127.0.0.1", 0))
    listener.settimeout(0.05)
    seen: list = []
    stop = threading.Event()

    def handle(conn: socket.socket) -> None:
        with conn:
            conn.settimeout(5)
            data = b""
            while b"\r\n\r\n" not in data:
                chunk = conn.recv(65536)
                if not chunk:
                    return
                data += chunk
            head, _, body = data.partition(b"\r\n\r\n")
            first, *lines = head.decode("latin-1").split("\r\n")
            headers = {k.lower(): v.strip() for k, v in (x.split(":", 1) for x in lines)}
            while len(body) < int(headers.get("content-length", 0)):
                body += conn.recv(65536)
            method, path, _ = first.split(" ")
            seen.append((method, path, headers))
            try:
                answer(path, conn)
            except OSError:  # the client gave up on it: as it should
                pass

    def accept() -> None:
        while not stop.is_set():
            try:
                conn, _ = listener.accept()
            except TimeoutError:
                continue
            threading.Thread(target=handle, args=(conn,), daemon=True).start()

    thread = threading.Thread(target=accept, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{listener.getsockname()[1]}", seen
    finally:
        stop.set()
        thread.join(5)
        listener.close()


def _only_on(bad_path: str, raw: bytes):
    """An answer function: ``raw`` on ``bad_path``, a good answer on the other path."""

    def answer(path: str, conn: socket.socket) -> None:
        if path == bad_path:
            conn.sendall(raw)
        else:
            health = path.endswith("/health")
            conn.sendall(_http(HEALTH if health else json.dumps(GOOD).encode()))

    return answer


def _ask(url: str, limits=None):
    """The /health check, then one frame."""
    ServerPerceiver(url, limits)(_frame(), "panda", True, CONFIG)


def _one_line(info) -> str:
    message = str(info.value)
    assert isinstance(info.value, MomaError) and "\n" not in message, message
    return message


HOSTILE = {
    "bad status line": (b"HTTP/1.1 abc\r\n\r\n", "bad HTTP status line: 'HTTP/1.1 abc"),
    "101 headers": (
        b"HTTP/1.1 200 OK\r\n" + b"X-Junk: y\r\n" * 101 + b"\r\n",
        "malformed HTTP answer: got more than 100 headers",
    ),
    "truncated body": (
        b"HTTP/1.1 200 OK\r\nContent-Length: 1000\r\n\r\n" + HEALTH[:-1],
        "truncated body: 16 bytes, 984 more announced",
    ),
    "deep JSON": (_http(b"[" * 200_000 + b"]" * 200_000), "JSON nested too deeply"),
    "5000-digit integer": (
        _http(b'{"model": "m", "n": ' + b"7" * 5000 + b"}"),
        "JSON with an integer of 5000 digits",
    ),
    "500 MB announced": (
        b"HTTP/1.1 200 OK\r\nContent-Length: 500000000\r\n\r\n{",
        "answered more than 33554432 bytes (the answer limit)",
    ),
    "a redirect": (
        _http(b"", "302 Found", "Location: http://127.0.0.1:9/elsewhere\r\n"),
        "redirect (HTTP 302 to 'http://127.0.0.1:9/elsewhere'): redirects are not followed",
    ),
}


@pytest.mark.parametrize("path", ["/health", "/predict"])
@pytest.mark.parametrize("case", list(HOSTILE))
def test_malformed_http_answers_are_one_line_errors(path, case):
    raw, message = HOSTILE[case]
    with _raw_server(_only_on(path, raw)) as (url, _):
        t0 = time.monotonic()
        with pytest.raises(ServerError) as info:
            _ask(url, ClientLimits(timeout=5, health_timeout=5))
    assert f"'{url}'{path} " in _one_line(info) and message in str(info.value), str(info.value)
    assert time.monotonic() - t0 < 5


def test_a_dripping_server_is_cut_off_at_the_deadline():
    def drip(path: str, conn: socket.socket) -> None:
        if path == "/health":
            conn.sendall(_http(HEALTH))
            return
        for byte in _http(json.dumps(GOOD).encode()):
            conn.sendall(bytes([byte]))
            time.sleep(0.25)

    with _raw_server(drip) as (url, _):
        server = ServerPerceiver(url, ClientLimits(timeout=1.0, health_timeout=30))
        t0 = time.monotonic()
        with pytest.raises(ServerError) as info:
            server(_frame(), "panda", True, CONFIG)
        seconds = time.monotonic() - t0
    # each byte comes well within a second: only the deadline of the whole request stops it
    assert "/predict did not answer within 1 s (the request deadline)" in _one_line(info)
    assert 0.9 < seconds < 2.0, seconds


def test_a_flood_is_cut_off_at_the_byte_cap_while_it_is_read():
    def flood(path: str, conn: socket.socket) -> None:
        if path == "/health":
            conn.sendall(_http(HEALTH))
            return
        conn.sendall(b"HTTP/1.1 200 OK\r\nConnection: close\r\n\r\n[")  # no length: to the end
        block = b"0," * 32768
        for _ in range(8000):  # 500 MB, unless the client hangs up first
            conn.sendall(block)

    cap = 1024 * 1024
    with _raw_server(flood) as (url, _):
        server = ServerPerceiver(url, ClientLimits(max_answer_bytes=cap))
        tracemalloc.start()
        try:
            with pytest.raises(ServerError) as info:
                server(_frame(), "panda", True, CONFIG)
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
    assert f"answered more than {cap} bytes (the answer limit)" in _one_line(info)
    assert peak < 4 * cap, peak


def test_a_redirect_never_carries_the_token_elsewhere(monkeypatch):
    monkeypatch.setenv("MOMAKITCHEN_SERVE_TOKEN", "s3cret")
    with _raw_server(_only_on("/nothing", b"")) as (elsewhere, stolen):
        moved = _http(b"", "307 Temporary Redirect", f"Location: {elsewhere}/predict\r\n")
        with _raw_server(_only_on("/predict", moved)) as (url, seen):
            server = ServerPerceiver(url)
            with pytest.raises(ServerError, match=r"HTTP 307 to .*redirects are not followed"):
                server(_frame(), "panda", True, CONFIG)
            time.sleep(0.1)
    assert [(m, p) for m, p, _ in seen] == [("GET", "/health"), ("POST", "/predict")]
    assert all(h["authorization"] == "Bearer s3cret" for _, _, h in seen)
    assert stolen == []  # neither the token nor a GET turned from the POST went there


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"target_xyz": [2.0, "0.1", 0.8]}, "target_xyz[1] must be a JSON number, got '0.1'"),
        ({"target_xyz": [2.0, True, 0.8]}, "target_xyz[1] must be a JSON number, got True"),
        ({"target_xyz": [1e999, 0.1, 0.8]}, "target_xyz[0] = inf is non-finite"),
        ({"poses": [{**GOOD["poses"][0], "x": "1"}]}, "poses[0].x must be a JSON number"),
        ({"poses": [{**GOOD["poses"][0], "affordance": 1.01}]}, "poses[0].affordance = 1.01 is"),
        ({"poses": [{**GOOD["poses"][0], "uncertainty": -0.5}]}, "poses[0].uncertainty = -0.5"),
        ({"poses": [{"x": 1.0}]}, "poses[0] must be an object with x, y, yaw, affordance"),
        ({"poses": {}}, "'poses' must be a list, got {}"),
        (
            {"floor_points": {"rows": [[1, 0, 0, -0.2, 0]]}},
            "floor_points.rows[0][3] = -0.2 is outside [0, 1]",
        ),
        (
            {"floor_points": {"rows": [[1, 0, 0, 0.2, -1]]}},
            "floor_points.rows[0][4] = -1 is negative",
        ),
        (
            {"floor_points": {"rows": [[1, 0, 0, 0.2]]}},
            "floor_points.rows[0] must be a list of 5 numbers",
        ),
        (
            {"floor_points": {"rows": [[1, "NaN", 0, 0.2, 0]]}},
            "floor_points.rows[0][1] must be a JSON number",
        ),
        (
            {"floor_points": {"columns": ["x", "y"], "rows": []}},
            "floor_points.columns must be ['x', 'y', 'z', 'affordance', 'uncertainty']",
        ),
        ({"model": 3}, "'model' must be a string, got 3"),
    ],
)
def test_answers_are_checked_against_the_schema(change, message):
    body = json.dumps({**GOOD, **change}).encode()
    with _raw_server(_only_on("/predict", _http(body))) as (url, _):
        with pytest.raises(ServerError) as info:
            _ask(url)
    assert "answered a malformed prediction: " + message in _one_line(info), str(info.value)


def test_the_schema_accepts_the_documented_answer():
    doc = {**GOOD, "model": "theirs", "target_xyz": [2, 0, 1], "extra": {"ignored": [1]}}
    doc["floor_points"] = {"rows": [[1, 0, 0, 0, 0], [1, 0, 0, 1, 2.5]]}  # columns optional
    with _raw_server(_only_on("/predict", _http(json.dumps(doc).encode()))) as (url, _):
        pred = ServerPerceiver(url)(_frame(), "panda", True, CONFIG)
    assert pred.model == "theirs" and pred.target_xyz.tolist() == [2, 0, 1]
    np.testing.assert_allclose(pred.affordance, [0, 1])


@pytest.mark.parametrize(
    ("url", "message"),
    [
        ("http://[::1", "'http://[::1' is malformed: Invalid IPv6 URL"),
        ("http://127.0.0.1:abc", "'http://127.0.0.1:abc' is malformed: Port could not be cast"),
        ("http://127.0.0.1:70000", "'http://127.0.0.1:70000' is malformed: Port out of range"),
        ("http://:8000", "names no host"),
        ("http://me:pw@127.0.0.1:8000", "'http://***@127.0.0.1:8000' holds a user name or"),
        ("http://127.0.0.1:8000/?x=1", "has a query or fragment"),
        ("http://127.0.0.1 :8000", "must not hold spaces"),
        ("ftp://127.0.0.1", "http:// or https:// URL, got 'ftp://127.0.0.1'"),
    ],
)
def test_bad_urls_are_refused_before_any_request(url, message):
    with pytest.raises(MomaError) as info:
        ServerPerceiver(url)
    assert message in _one_line(info) and not isinstance(info.value, ServerError)
    assert "pw" not in str(info.value)


def test_a_url_prefix_and_ipv6_are_kept():
    with _raw_server(_only_on("/none", b"")) as (url, seen):
        ServerPerceiver(url + "/models/a/")
    assert seen[0][1] == "/models/a/health"
    assert client_module.server_url("http://[::1]:8000/x") == ("http", "::1", 8000, "/x")
    assert client_module.server_url("https://example.org") == ("https", "example.org", 443, "")


def test_the_limits_are_checked(monkeypatch):
    for kwargs, message in [
        ({"timeout": 0}, r"timeout must be in \(0, 3600\] s, got 0"),
        ({"timeout": float("nan")}, "got nan"),
        ({"health_timeout": "5"}, "health_timeout must be a number of seconds, got '5'"),
        ({"max_answer_bytes": 10}, r"max_answer_bytes must be an integer in \[1024, 2\*\*30\]"),
        ({"max_answer_bytes": 2.5e6}, "got 2500000.0"),
        ({"busy_retries": -1}, r"busy_retries must be an integer in \[0, 100\], got -1"),
    ]:
        with pytest.raises(MomaError, match=message):
            ClientLimits(**kwargs)
    monkeypatch.setenv("MOMAKITCHEN_SERVE_TOKEN", "caf\u00e9")
    with pytest.raises(MomaError, match="must be printable ASCII") as info:
        ServerPerceiver("http://127.0.0.1:9")
    assert "caf" not in str(info.value)  # a secret is never printed


def test_busy_retries_are_limited():
    with _raw_server(_only_on("/predict", _http(b"busy", "503 Busy", "Retry-After: 0\r\n"))) as (
        url,
        seen,
    ):
        with pytest.raises(ServerError, match="HTTP 503: busy"):
            _ask(url, ClientLimits(busy_retries=2))
    assert [p for _, p, _ in seen] == ["/health"] + ["/predict"] * 3


@pytest.mark.parametrize(
    ("url", "message"),
    [
        ("http://[::1", "--server URL 'http://[::1' is malformed: Invalid IPv6 URL"),
        ("http://127.0.0.1:abc", "--server URL 'http://127.0.0.1:abc' is malformed: Port"),
        (None, "/health answered a bad HTTP status line: 'HTTP/1.1 abc"),
    ],
)
def test_the_command_line_says_one_line_and_exits_2(real_view, tmp_path, capsys, url, message):
    from momakitchen.cli.main import main

    with _raw_server(_only_on("/health", HOSTILE["bad status line"][0])) as (hostile, _):
        argv = ["approach", "--data", str(real_view), "--json", str(tmp_path / "a.json")]
        code = main([*argv, "--server", url or hostile, "--quiet"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and message in err and "\n" not in err, err
    assert "Traceback" not in err
