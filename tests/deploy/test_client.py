"""The client of serve's API that the approach track calls: busy servers, refused
frames and answers that are not predictions."""

from __future__ import annotations

import json
import threading
from http.server import BaseHTTPRequestHandler, HTTPServer
from types import SimpleNamespace

import numpy as np
import pytest

from momakitchen.deploy import client as client_module
from momakitchen.deploy.client import ServerError, ServerPerceiver
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


def test_no_server_is_an_error_before_any_work(monkeypatch):
    monkeypatch.setattr(client_module, "BUSY_RETRIES", 0)
    with pytest.raises(ServerError, match="cannot reach server"):
        ServerPerceiver("http://127.0.0.1:9")
    with pytest.raises(MomaError, match="http:// or https://"):
        ServerPerceiver("127.0.0.1:8000")
