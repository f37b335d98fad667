"""The limits of momakitchen serve, on the real aiohttp server in this process with a model
that only sleeps: the queue (503 + Retry-After), the in-flight bytes, the read timeouts
(trickled headers and body), the token, a client that leaves, image and .npy headers
checked before decoding, and no traceback for any of it."""

from __future__ import annotations

import gzip
import json
import logging
import socket
import threading
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

pytest.importorskip("aiohttp")

from server_helpers import CAMERA, H, W, form, get, multipart, npy, png, post, running

from momakitchen.deploy import server as srv
from momakitchen.deploy.server_inputs import predict_arguments
from momakitchen.errors import MomaError


class SleepyServer(srv.ModelServer):
    """The server with a model that sleeps ``delay`` s and records who it predicted for
    (the request's ``robot`` field)."""

    def __init__(self, token: str | None = None, **limits: float) -> None:
        run = SimpleNamespace(
            config=SimpleNamespace(model="fake"), run_dir=Path("/home/someone/runs/fake")
        )
        super().__init__(run, limits=srv.Limits(**limits), token=token)  # type: ignore[arg-type]
        self.delay = 0.0
        self.calls: list[str] = []

    def predict(self, files, text):
        self.calls.append(text["robot"])
        time.sleep(self.delay)
        return {"robot": text["robot"], "poses": []}, self.delay


def one_line_error(doc) -> str:
    assert set(doc) == {"error"} and "\n" not in doc["error"], doc
    return doc["error"]


def closed_within(sock: socket.socket, seconds: float) -> tuple[bytes, float]:
    """Everything the server sends until it closes ``sock``, and when it did."""
    t0 = time.monotonic()
    sock.settimeout(seconds)
    data = b""
    try:
        while chunk := sock.recv(65536):
            data += chunk
    except ConnectionResetError:
        pass
    except TimeoutError:
        return data, float("inf")
    return data, time.monotonic() - t0


@pytest.fixture
def no_tracebacks(caplog):
    """Fails the test if anything logged an exception (aiohttp logs a handler's
    unexpected exceptions with their traceback)."""
    caplog.set_level(logging.DEBUG, logger="aiohttp")
    yield
    # caplog.records here would be the teardown's only: the test's own are the call's
    records = caplog.get_records("call") + caplog.records
    bad = [r for r in records if r.exc_info and r.levelno >= logging.WARNING]
    assert not bad, [r.getMessage() for r in bad]


def test_a_full_queue_answers_503_with_retry_after(no_tracebacks):
    server = SleepyServer(queue=1)
    server.delay = 2.0
    answers: dict[int, tuple] = {}
    with running(server) as addr:

        def send(i: int) -> None:
            answers[i] = post(addr, *form(f"r{i}"))

        threads = [threading.Thread(target=send, args=(i,)) for i in range(5)]
        for t in threads:
            t.start()
            time.sleep(0.2)  # in this order: the first runs, the second waits
        for t in threads:
            t.join(30)
        statuses = [answers[i][0] for i in range(5)]
        # one predicted, one waiting: the other three are refused before their body is read
        assert statuses[:2] == [200, 200] and statuses[2:] == [503, 503, 503], statuses
        for i in range(2, 5):
            _, doc, headers = answers[i]
            assert "the model's queue is full: 1 waiting" in one_line_error(doc)
            assert int(headers["Retry-After"]) >= 1
        assert server.calls == ["r0", "r1"]
        # and once the queue has drained, the server takes requests again
        assert post(addr, *form("again"))[0] == 200
        assert server.queued == 0 and server.inflight == 0


def test_in_flight_bytes_are_capped(no_tracebacks):
    server = SleepyServer(max_body_mb=1, max_inflight_mb=2, read_timeout=10)
    mb = 1024 * 1024
    with running(server) as addr:
        status, doc, _ = post(addr, *form(files={"rgb": bytes(mb + 1)}))
        assert status == 413 and "larger than 1 MB" in one_line_error(doc)
        # two clients announce 0.9 MB bodies and send them slowly: 1.8 MB reserved
        slow = []
        for _ in range(2):
            s = socket.create_connection(addr)
            s.sendall(
                b"POST /predict HTTP/1.1\r\nHost: x\r\nContent-Type: multipart/form-data; "
                b"boundary=b\r\nContent-Length: %d\r\n\r\n--b\r\n" % (9 * mb // 10)
            )
            slow.append(s)
        time.sleep(0.3)
        assert server.inflight == 2 * (9 * mb // 10)
        body, ctype = form(files={"rgb": npy(np.zeros((H, W, 3), np.uint8))})
        status, doc, headers = post(addr, body + bytes(300_000), ctype)
        assert status == 503 and "2 MB of requests are in flight" in one_line_error(doc)
        assert int(headers["Retry-After"]) >= 1
        for s in slow:
            s.close()
        time.sleep(0.3)
        # their reservations are released with them
        assert server.inflight == 0
        assert post(addr, *form())[0] == 200


def test_slow_clients_are_cut_off(no_tracebacks):
    server = SleepyServer(read_timeout=1.0)
    with running(server) as addr:
        # headers trickled a byte every 0.2 s: closed after the read timeout, unanswered
        s = socket.create_connection(addr)
        head = b"POST /predict HTTP/1.1\r\nHost: x\r\nContent-Length: 10\r\n"
        t0 = time.monotonic()
        try:
            for byte in head:
                s.sendall(bytes([byte]))
                time.sleep(0.2)
        except (BrokenPipeError, ConnectionResetError):
            pass
        data, _ = closed_within(s, 5)
        assert data == b"" and time.monotonic() - t0 < 1.0 + 0.2 * 3 + 1.5
        s.close()
        # a connection that sends nothing at all
        s = socket.create_connection(addr)
        data, seconds = closed_within(s, 5)
        assert data == b"" and 0.8 < seconds < 3, seconds
        s.close()
        # the body trickled: 408 and the connection closed
        body, ctype = form()
        s = socket.create_connection(addr)
        s.sendall(
            f"POST /predict HTTP/1.1\r\nHost: x\r\nContent-Type: {ctype}\r\n"
            f"Content-Length: {len(body)}\r\n\r\n".encode()
        )
        t0 = time.monotonic()
        try:
            for i in range(0, 60):
                s.sendall(body[i : i + 1])
                time.sleep(0.1)
        except (BrokenPipeError, ConnectionResetError):
            pass
        data, _ = closed_within(s, 5)
        s.close()
        assert data.startswith(b"HTTP/1.1 408"), data[:200]
        assert b"did not arrive within 1 s" in data
        assert time.monotonic() - t0 < 1.0 + 6 + 1.5
        # a prompt client is served as ever
        assert post(addr, *form())[0] == 200


def test_clients_that_leave_cost_no_traceback_and_no_prediction(no_tracebacks):
    server = SleepyServer()
    server.delay = 1.5
    with running(server) as addr:
        first = threading.Thread(target=post, args=(addr, *form("first")))
        first.start()
        time.sleep(0.3)
        # a second client sends its frame, then leaves while the first is predicted
        body, ctype = form("gone")
        s = socket.create_connection(addr)
        s.sendall(
            f"POST /predict HTTP/1.1\r\nHost: x\r\nContent-Type: {ctype}\r\n"
            f"Content-Length: {len(body)}\r\n\r\n".encode()
            + body
        )
        time.sleep(0.3)
        assert server.queued == 2
        s.close()
        # a third resets its connection mid-body
        r = socket.create_connection(addr)
        r.sendall(
            f"POST /predict HTTP/1.1\r\nHost: x\r\nContent-Type: {ctype}\r\n"
            f"Content-Length: {len(body)}\r\n\r\n".encode()
            + body[:100]
        )
        time.sleep(0.1)
        r.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, b"\x01\x00\x00\x00\x00\x00\x00\x00")
        r.close()  # linger 0: an RST, ConnectionResetError on the server
        first.join(30)
        status, doc, _ = post(addr, *form("last"))
        assert status == 200 and doc["robot"] == "last"
        # the frame whose client had gone was never predicted
        assert server.calls == ["first", "last"]


def test_a_token_guards_every_route(no_tracebacks):
    server = SleepyServer(token="s3cret")
    with running(server) as addr:
        for headers in ({}, {"Authorization": "Bearer nope"}, {"Authorization": "s3cret"}):
            status, doc, hdrs = get(addr, "/health", headers)
            assert status == 401 and "Authorization: Bearer <token>" in one_line_error(doc)
            assert hdrs["WWW-Authenticate"] == "Bearer"
            status, doc, _ = post(addr, *form(), headers=headers)
            assert status == 401 and server.calls == []
        good = {"Authorization": "Bearer s3cret"}
        status, doc, _ = get(addr, "/health", good)
        assert status == 200 and doc["checkpoint"] == "fake"  # the run's name, no path
        assert post(addr, *form(), headers=good)[0] == 200
        # unknown routes and methods are one-line JSON too
        status, doc, _ = get(addr, "/nowhere", good)
        assert status == 404 and "/nowhere" in one_line_error(doc)
        status, doc, hdrs = get(addr, "/predict", good)
        assert status == 405 and "POST" in hdrs["Allow"]


def test_headers_are_checked_before_decoding(no_tracebacks):
    server = SleepyServer()
    big = 4097
    with running(server) as addr:
        cases = {
            # over 16 Mpx: a tiny PNG (1-bit) and a .npy that is only a header
            "is 4097x4097 = 16785409 pixels, over the limit of 16777216 (4096x4096)": {
                "depth": png(np.zeros((big, big), bool))
            },
            "'target_mask' is 5000x5000 = 25000000 pixels": {
                "target_mask": npy(np.zeros((1, 1), np.uint8))[:-1].replace(
                    b"(1, 1)", b"(5000, 5000)"
                )
            },
            "'depth' is a .npy of dtype [('a', '<f4'), ('b', '<i4')]: give a bool, integer": {
                "depth": npy(np.zeros((H, W), [("a", "f4"), ("b", "i4")]))
            },
            "'target_mask' is a .npy of dtype <U1": {"target_mask": npy(np.full((H, W), "x"))},
            "'target_mask' is a .npy of dtype object": {
                "target_mask": npy(np.full((H, W), None, object))
            },
            "'depth' is a .npy of dtype complex128": {"depth": npy(np.zeros((H, W), complex))},
            "'depth' is a truncated .npy": {"depth": npy(np.ones((H, W), np.float32))[:-4]},
            "'depth' must be an (H, W) or (H, W, C) image, got (6,)": {
                "depth": npy(np.ones(6, np.float32))
            },
            "'rgb' is 8x3: it does not match the depth image (8x6)": {
                "rgb": png(np.zeros((3, W, 3), np.uint8))
            },
            "'obstacle_mask' is given 17 times, more than 16": {
                "obstacle_mask": [npy(np.zeros((H, W), bool))] * 17
            },
        }
        for message, files in cases.items():
            status, doc, _ = post(addr, *form(files=files))
            assert status == 400, (message, doc)
            assert message in one_line_error(doc), (message, doc)
        numbers = {
            "mc_samples": ["65", "-1", "2.5", "nan"],
            "top_k": ["0", "51", "x", "1e3"],
            "min_spread": ["nan", "inf", "-0.1", "6"],
            "pick_radius": ["nan", "-inf", "1.5"],
        }
        for name, values in numbers.items():
            for value in values:
                status, doc, _ = post(addr, *form(**{name: value}))
                assert status == 400, (name, value, doc)
                assert f"field {name!r} must be" in one_line_error(doc)
                assert repr(value) in doc["error"], doc
        status, doc, _ = post(addr, *form(floor_points="2"))
        assert status == 400 and "'floor_points' must be 0 or 1" in one_line_error(doc)
        status, doc, _ = post(addr, *form(opens="yes"))
        assert status == 400 and "'opens' must be 0 or 1, got 'yes'" in one_line_error(doc)
        # accepted at the limits
        ok = {"mc_samples": "64", "top_k": "50", "min_spread": "0", "pick_radius": "1"}
        assert post(addr, *form(**ok))[0] == 200
        body, ctype = form()
        status, doc, _ = post(addr, body, ctype, {"Content-Encoding": "gzip"})
        assert status == 415 and "'gzip' is not accepted" in one_line_error(doc)
        assert len(server.calls) == 1  # no refused request reached the model


def test_the_limits_themselves_are_checked():
    with pytest.raises(MomaError, match=r"in-flight limit \(64 MB\) must be at least"):
        srv.Limits(max_body_mb=65, max_inflight_mb=64)
    with pytest.raises(MomaError, match="read timeout must be > 0 s, got nan"):
        srv.Limits(read_timeout=float("nan"))
    with pytest.raises(MomaError, match="queue must be >= 0"):
        srv.Limits(queue=-1)
    assert srv.is_loopback("127.0.0.1") and srv.is_loopback("::1")
    assert srv.is_loopback("localhost") and srv.is_loopback("127.3.2.1")
    assert not srv.is_loopback("0.0.0.0") and not srv.is_loopback("192.168.1.5")
    assert not srv.is_loopback("robot.local") and not srv.is_loopback("")
    with pytest.raises(MomaError, match=r"refusing to serve 0\.0\.0\.0 without a token"):
        srv.serve("0.0.0.0", 0, checkpoint="/nowhere")
    with pytest.raises(MomaError, match="the token is empty"):
        srv.serve("0.0.0.0", 0, checkpoint="/nowhere", token=" ")


def test_health_names_the_bundled_run_without_its_path():
    from momakitchen.train.checkpoint import DEFAULT_CHECKPOINT

    assert srv.checkpoint_label(DEFAULT_CHECKPOINT) == "navaff (bundled)"
    assert srv.checkpoint_label("/home/someone/runs/navaff-12ep") == "navaff-12ep"


def _raw(addr, data: bytes) -> tuple[int, dict, bytes]:
    """Status, JSON answer and head of ``data`` sent as is (it asks the server to close)."""
    with socket.create_connection(addr) as s:
        s.sendall(data)
        answer, seconds = closed_within(s, 10)
    assert seconds < 10, answer[:200]
    head, _, body = answer.partition(b"\r\n\r\n")
    return int(head.split()[1]), json.loads(body), head


def _request(body: bytes, ctype: str, **headers: str) -> bytes:
    head = {"Host": "x", "Content-Type": ctype, "Content-Length": str(len(body))}
    head.update({k.replace("_", "-"): v for k, v in headers.items()})
    head["Connection"] = "close"
    lines = "".join(f"{k}: {v}\r\n" for k, v in head.items())
    return f"POST /predict HTTP/1.1\r\n{lines}\r\n".encode() + body


def test_malformed_requests_and_forms_get_one_line_json(no_tracebacks):
    server = SleepyServer()
    body, ctype = form()
    boundary = ctype.split("boundary=")[1].encode()
    with running(server) as addr:
        cases = [
            # a 600 kB line before the first boundary
            (_request(b"x" * 600_000 + b"\r\n" + body, ctype), 400, "malformed multipart body"),
            # 1,000 small fields: too many, whatever their size
            (
                _request(*multipart({f"f{i}": "1" for i in range(1000)}, {})),
                413,
                "the form has more than 64 fields (the limit)",
            ),
            (
                _request(*form(robot="r" * 5000)),
                413,
                "text field 'robot' is over 4096 bytes (the limit of a text field)",
            ),
            (
                _request(*form(), Content_Length="-5"),
                400,
                "malformed HTTP request: Invalid character in Content-Length",
            ),
            (b"NOT HTTP AT ALL\r\n\r\n", 400, "malformed HTTP request"),
            (
                _request(
                    body.replace(b"\r\n\r\n", b"\r\nContent-Encoding: gzip\r\n\r\n", 1), ctype
                ),
                415,
                "has Content-Encoding 'gzip': send it plain",
            ),
            (
                _request(
                    body.replace(b"--" + boundary + b"\r\n", b"--" + boundary + b"\r\nX: y\r\n", 1),
                    ctype,
                ),
                200,
                "",
            ),
        ]
        for data, status, message in cases:
            got, doc, head = _raw(addr, data)
            assert got == status, (message, got, doc)
            assert b"application/json" in head
            if message:
                assert message in one_line_error(doc), (message, doc)
        assert post(addr, *form())[0] == 200  # and it serves on
    assert server.calls == ["r", "r"]


def test_encoded_bodies_are_refused_unread(no_tracebacks):
    server = SleepyServer()
    body, ctype = form(files={"rgb": np.random.default_rng(0).bytes(2_000_000)})
    with running(server) as addr:
        # not gzip at all, gzip, and a gzip bomb (200 MB of zeros): 415, never inflated
        for data in (body, gzip.compress(body), gzip.compress(bytes(200_000_000), 1)):
            status, doc, _ = _raw(addr, _request(data, ctype, Content_Encoding="gzip"))
            assert status == 415 and "'gzip' is not accepted" in one_line_error(doc)
        assert post(addr, *form())[0] == 200
    assert server.calls == ["r"]


class DecodingServer(SleepyServer):
    """The server that decodes each request's fields as the real model's does."""

    def predict(self, files, text):
        predict_arguments(files, text)
        return super().predict(files, text)


def test_opens_reaches_predict_as_a_flag():
    """The request's ``opens`` (0 or 1; default 0) is ``predict``'s ``opens``."""
    parts = {"depth": [npy(np.ones((H, W), np.float32))], "target_mask": [npy(np.ones((H, W)))]}
    text = {"intrinsics": "4 4 4 3", "camera_to_base": CAMERA, "robot": "panda"}
    assert predict_arguments(parts, text)[0]["opens"] is False
    assert predict_arguments(parts, {**text, "opens": "1"})[0]["opens"] is True


def test_non_finite_numbers_and_colours_are_named(no_tracebacks):
    server = DecodingServer()
    with running(server) as addr:
        cases = {
            "field 'intrinsics' must be 4 finite numbers, got 'nan' in '4 nan 4 3'": form(
                intrinsics="4 nan 4 3"
            ),
            "field 'camera_to_base' must be 16 finite numbers, got '-inf' in": form(
                camera_to_base="1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 -inf"
            ),
            "field 'intrinsics' must be 4 finite numbers, got 3: '4 4 4'": form(intrinsics="4 4 4"),
            "field 'reach' must be 1 finite numbers, got 'inf' in 'inf'": multipart(
                {"intrinsics": "4 4 4 3", "camera_to_base": CAMERA, "reach": "inf"}
                | {"mount_height": "1"},
                {"depth": npy(np.ones((H, W), np.float32)), "target_mask": npy(np.ones((H, W)))},
            ),
            "field 'rgb' holds 144 non-finite values (e.g. nan): give finite numbers": form(
                files={"rgb": npy(np.full((H, W, 3), np.nan, np.float32))}
            ),
            "field 'obstacle_mask 0' holds 1 non-finite values (e.g. inf)": form(
                files={"obstacle_mask": npy(_one_inf())}
            ),
        }
        for message, (body, ctype) in cases.items():
            status, doc, _ = post(addr, body, ctype)
            assert status == 400 and message in one_line_error(doc), (message, doc)
        rgb = np.random.default_rng(0).random((H, W, 3)).astype(np.float32)
        assert post(addr, *form(files={"rgb": npy(rgb)}))[0] == 200  # finite floats are fine
    assert server.calls == ["r"]


def _one_inf() -> np.ndarray:
    out = np.zeros((H, W))
    out[2, 3] = np.inf
    return out
