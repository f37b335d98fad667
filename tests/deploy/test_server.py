"""momakitchen serve: the real server on a free localhost port, real HTTP requests (good,
concurrent and bad), answers equal to momakitchen.predict on the same inputs."""

from __future__ import annotations

import io
import json
import re
import subprocess
import threading
import urllib.error
import urllib.request
import uuid
from pathlib import Path

import numpy as np
import pytest

from cli_process import cli_process, serve_process

pytest.importorskip("aiohttp")

import momakitchen
from momakitchen.data.episode import SEMANTIC_CLASSES
from momakitchen.data.shard import SceneShard
from momakitchen.version import __version__

ROOT = Path(__file__).resolve().parents[2]
TARGET = SEMANTIC_CLASSES.index("target")
OBSTACLE = SEMANTIC_CLASSES.index("obstacle")


@pytest.fixture(scope="module")
def episodes(real_view):
    with SceneShard(real_view / "scenes" / "scene_000003.h5") as shard:
        return [shard.episode(0, i) for i in shard.episode_indices(0)]


@pytest.fixture(scope="module")
def server():
    """``momakitchen serve`` in its own process on a free port of 127.0.0.1."""
    with serve_process() as url:
        yield url


def _png(array: np.ndarray) -> bytes:
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(array).save(buf, format="PNG")
    return buf.getvalue()


def _npy(array: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.save(buf, array)
    return buf.getvalue()


def _post(url: str, files: dict, fields: dict, content_type: str | None = None):
    """POST a multipart form (stdlib only); returns (status, JSON or text)."""
    boundary = uuid.uuid4().hex
    body = io.BytesIO()
    parts = [(k, v, None) for k, v in fields.items()]
    for name, value in files.items():
        for i, data in enumerate(value if isinstance(value, list) else [value]):
            parts.append((name, data, f"{name}{i}.bin"))
    for name, value, filename in parts:
        body.write(f"--{boundary}\r\n".encode())
        disp = f'form-data; name="{name}"' + (f'; filename="{filename}"' if filename else "")
        body.write(f"Content-Disposition: {disp}\r\n\r\n".encode())
        body.write(value if isinstance(value, bytes) else str(value).encode())
        body.write(b"\r\n")
    body.write(f"--{boundary}--\r\n".encode())
    req = urllib.request.Request(
        f"{url}/predict",
        data=body.getvalue(),
        headers={"Content-Type": content_type or f"multipart/form-data; boundary={boundary}"},
    )
    try:
        with urllib.request.urlopen(req, timeout=60) as r:
            return r.status, json.loads(r.read()), dict(r.headers)
    except urllib.error.HTTPError as e:
        text = e.read().decode()
        try:
            return e.code, json.loads(text), dict(e.headers)
        except json.JSONDecodeError:
            return e.code, text, dict(e.headers)


def _request(ep, **extra):
    files = {
        "depth": _png(np.round(ep.depth * 1000).astype(np.uint16)),
        "rgb": _png(ep.rgb),
        "target_mask": _png((ep.semantic == TARGET).astype(np.uint8) * 255),
        "obstacle_mask": [_png((ep.semantic == OBSTACLE).astype(np.uint8) * 255)],
    }
    fields = {
        "intrinsics": " ".join(repr(float(v)) for v in ep.intrinsics),
        "camera_to_base": ",".join(repr(float(v)) for v in ep.camera_to_base.ravel()),
        "robot": ep.robot,
        "mc_samples": "0",
    }
    for k, v in extra.items():
        (files if isinstance(v, (bytes, list)) else fields)[k] = v
    return files, fields


def _expected(ep, top_k=5, depth=None):
    return momakitchen.predict(
        np.round(ep.depth * 1000) / 1000 if depth is None else depth,
        ep.intrinsics,
        ep.camera_to_base,
        ep.semantic == TARGET,
        ep.robot,
        rgb=ep.rgb,
        obstacle_masks=[ep.semantic == OBSTACLE],
        top_k=top_k,
        mc_samples=0,
    )


def _check(doc, pred, floor_points=True):
    got = np.array([[p["x"], p["y"], p["yaw"]] for p in doc["poses"]])
    np.testing.assert_allclose(got, pred.poses, rtol=0, atol=1e-3)
    ref = pred.to_dict(floor_points=floor_points)
    assert doc["poses"] == ref["poses"] and doc["target_xyz"] == ref["target_xyz"]
    assert ("floor_points" in doc) == floor_points
    if floor_points:
        assert len(doc["floor_points"]["rows"]) == len(pred.floor_xyz)


def test_health_and_a_640x480_frame(server, episodes):
    with urllib.request.urlopen(f"{server}/health", timeout=10) as r:
        health = json.loads(r.read())
    assert health["status"] == "ok" and health["model"] == "navaff"
    assert health["version"] == __version__
    assert health["checkpoint"] == "navaff (bundled)"  # its name, not the server's path
    ep = episodes[0]
    assert ep.depth.shape == (480, 640)
    status, doc, headers = _post(server, *_request(ep))
    assert status == 200, doc
    _check(doc, _expected(ep))
    assert float(headers["X-Predict-Seconds"]) > 0
    # depth as .npy in metres, without the floor points
    files, fields = _request(ep, floor_points="0", top_k="3")
    files["depth"] = _npy(ep.depth)
    status, doc, _ = _post(server, files, fields)
    assert status == 200, doc
    _check(doc, _expected(ep, top_k=3, depth=ep.depth), floor_points=False)


def test_concurrent_requests_get_their_own_answers(server, episodes):
    # five at once: the one being predicted and the four the default queue holds
    jobs = [(episodes[i % 2], k) for i, k in enumerate((1, 2, 3, 4, 5))]
    answers: dict[int, tuple] = {}

    def send(i, ep, k):
        answers[i] = _post(server, *_request(ep, top_k=str(k), floor_points="0"))

    threads = [threading.Thread(target=send, args=(i, ep, k)) for i, (ep, k) in enumerate(jobs)]
    for t in threads:
        t.start()
    # the server answers /health while the frames are predicted
    with urllib.request.urlopen(f"{server}/health", timeout=10) as r:
        assert r.status == 200
    for t in threads:
        t.join(120)
    expected = {(id(ep), k): _expected(ep, top_k=k) for ep, k in jobs}
    for i, (ep, k) in enumerate(jobs):
        status, doc, _ = answers[i]
        assert status == 200, doc
        assert len(doc["poses"]) == k
        _check(doc, expected[(id(ep), k)], floor_points=False)


def test_bad_requests_get_a_4xx_and_one_line(server, episodes):
    ep = episodes[1]
    files, fields = _request(ep)

    def without(d, key):
        return {k: v for k, v in d.items() if k != key}

    flat = np.zeros((480, 640), np.uint16)
    cases = {
        "missing field 'depth'": (without(files, "depth"), fields),
        "unknown field 'colour'": (files, {**fields, "colour": "1"}),
        "field 'depth' must be a PNG, JPEG or .npy file": ({**files, "depth": b"GIF89a"}, fields),
        "depth PNG must be 16-bit": ({**files, "depth": _png(flat.astype(np.uint8))}, fields),
        "not a readable .npy array": ({**files, "depth": b"\x93NUMPY garbage"}, fields),
        "field 'intrinsics' must be 4 finite numbers, got 3": (
            files,
            {**fields, "intrinsics": "1 2 3"},
        ),
        "field 'camera_to_base' must be 16 numbers": (
            files,
            {**fields, "camera_to_base": "a b"},
        ),
        "not a rigid transform": (files, {**fields, "camera_to_base": " ".join(["2"] * 16)}),
        "unknown robot": (files, {**fields, "robot": "r2d2"}),
        "missing field 'robot'": (files, without(fields, "robot")),
        "target mask is empty": ({**files, "target_mask": _png(flat.astype(np.uint8))}, fields),
        "no valid pixel": ({**files, "depth": _png(flat)}, fields),
        r"field 'top_k' must be an integer in \[1, 50\], got '0'": (
            files,
            {**fields, "top_k": "0"},
        ),
        r"field 'top_k' must be an integer in \[1, 50\], got 'x'": (
            files,
            {**fields, "top_k": "x"},
        ),
        r"field 'mc_samples' must be an integer in \[0, 64\], got '1000'": (
            files,
            {**fields, "mc_samples": "1000"},
        ),
        r"field 'min_spread' must be a finite number \(m\) in \[0, 5\], got 'nan'": (
            files,
            {**fields, "min_spread": "nan"},
        ),
        r"field 'depth' is a .npy of dtype \[\('d', '<f4'\)\]": (
            {**files, "depth": _npy(np.zeros((480, 640), [("d", "<f4")]))},
            fields,
        ),
        r"field 'target_mask' is a .npy of dtype <U1": (
            {**files, "target_mask": _npy(np.full((480, 640), "t"))},
            fields,
        ),
        "does not match the depth image": (
            {**files, "rgb": _png(ep.rgb[:100])},
            fields,
        ),
        "field 'robot' must be text": ({**files, "robot": b"panda"}, without(fields, "robot")),
        "suction must be 0 or 1, got 'yes'": (
            files,
            {**without(fields, "robot"), "reach": "0.8", "mount_height": "1", "suction": "yes"},
        ),
        r"robot finger_force must be in \[10, 200\] N, got 500": (
            files,
            {
                **without(fields, "robot"),
                "reach": "0.8",
                "mount_height": "1",
                "finger_force": "500",
            },
        ),
    }
    for message, (f, d) in cases.items():
        status, doc, _ = _post(server, f, d)
        assert status == 400, (message, doc)
        assert set(doc) == {"error"} and "\n" not in doc["error"], doc
        assert re.search(message, doc["error"]), (message, doc["error"])
    status, doc, _ = _post(server, {**files, "depth": bytes(65 * 2**20)}, fields)
    assert status == 413 and "larger than 64 MB" in doc["error"]
    status, doc, _ = _post(server, files, fields, content_type="application/json")
    assert status == 415 and "multipart/form-data" in doc["error"]
    with pytest.raises(urllib.error.HTTPError) as info:
        urllib.request.urlopen(f"{server}/predict", timeout=10)
    assert info.value.code == 405 and "GET /predict" in json.loads(info.value.read())["error"]
    # the server is still well after all that
    status, doc, _ = _post(server, *_request(ep, floor_points="0"))
    assert status == 200


def test_a_robot_given_by_its_numbers(server, episodes):
    from momakitchen.deploy.client import _robot_fields
    from momakitchen.robots.descriptor import robot_descriptor
    from momakitchen.robots.spec import get_robot_spec

    ep = episodes[0]
    numbers = dict(_robot_fields(robot_descriptor(get_robot_spec("elephant"), 0.9)))
    assert numbers == {
        "reach": "0.63",
        "mount_height": "0.9",
        "dof": "6",
        "suction": "0",
        "finger_force": "40",
        "shoulder_rise": "0.22934",
        "shoulder_offset": "0",
    }
    files, fields = _request(ep, floor_points="0")
    del fields["robot"]
    status, doc, _ = _post(server, files, {**fields, **numbers})
    assert status == 200, doc
    expected = momakitchen.predict(
        np.round(ep.depth * 1000) / 1000,
        ep.intrinsics,
        ep.camera_to_base,
        ep.semantic == TARGET,
        {
            "reach": 0.63,
            "mount_height": 0.9,
            "dof": 6,
            "finger_force": 40,
            "shoulder_rise": 0.22934,
            "shoulder_offset": 0.0,
        },
        rgb=ep.rgb,
        obstacle_masks=[ep.semantic == OBSTACLE],
        mc_samples=0,
    )
    _check(doc, expected, floor_points=False)
    assert "finger_force" not in dict(_robot_fields(robot_descriptor(get_robot_spec("ur5e"))))


def test_the_documented_client(server, episodes):
    """The robot-side client of docs/ROBOT_IO.md, run as written."""
    pytest.importorskip("requests")
    doc = (ROOT / "docs" / "ROBOT_IO.md").read_text(encoding="utf-8")
    (block,) = [
        b for b in re.findall(r"```python\n(.*?)```", doc, re.S) if "def request_base_pose" in b
    ]
    namespace: dict = {}
    exec(compile(block, "ROBOT_IO.md", "exec"), namespace)
    ep = episodes[0]
    poses = namespace["request_base_pose"](
        server,
        np.round(ep.depth * 1000).astype(np.uint16),
        ep.rgb,
        ep.semantic == TARGET,
        ep.intrinsics,
        ep.camera_to_base,
        robot=ep.robot,
    )
    expected = momakitchen.predict(
        np.round(ep.depth * 1000) / 1000,
        ep.intrinsics,
        ep.camera_to_base,
        ep.semantic == TARGET,
        ep.robot,
        rgb=ep.rgb,
    )
    assert poses == expected.to_dict(floor_points=False)["poses"]


def test_serving_another_address_needs_a_token(tmp_path):
    argv, env = cli_process("serve", "--host", "0.0.0.0", "--port", "0")
    env.pop("MOMAKITCHEN_SERVE_TOKEN", None)
    done = subprocess.run(argv, env=env, capture_output=True, text=True, timeout=60)
    assert done.returncode == 2 and done.stdout == ""
    assert done.stderr.count("\n") == 1, done.stderr
    assert "refusing to serve 0.0.0.0 without a token" in done.stderr
    assert "MOMAKITCHEN_SERVE_TOKEN" in done.stderr


def test_a_registered_robot_at_a_drawn_mount(server, episodes):
    """``robot`` and ``mount_height``: the model reads that robot's numbers at that mount."""
    from momakitchen.deploy.client import _robot_fields
    from momakitchen.robots.descriptor import robot_descriptor
    from momakitchen.robots.spec import get_robot_spec

    ep = episodes[0]
    fields_of = dict(_robot_fields(("elephant", 0.9)))
    assert fields_of == {"robot": "elephant", "mount_height": "0.9"}
    files, fields = _request(ep, floor_points="0")
    status, doc, _ = _post(server, files, {**fields, **fields_of})
    assert status == 200, doc
    expected = momakitchen.predict(
        np.round(ep.depth * 1000) / 1000,
        ep.intrinsics,
        ep.camera_to_base,
        ep.semantic == TARGET,
        robot_descriptor(get_robot_spec("elephant"), 0.9),
        rgb=ep.rgb,
        obstacle_masks=[ep.semantic == OBSTACLE],
        mc_samples=0,
    )
    _check(doc, expected, floor_points=False)
    assert doc["robot"] == "elephant"  # by name: a model may read its URDF
    status, doc, _ = _post(server, files, {**fields, "robot": "elephant", "mount_height": "3"})
    assert status == 400 and "mount_height" in doc["error"]


def test_a_classical_method_served(episodes):
    """``serve --method ring``: the same API, the method's map; no model loaded."""
    from momakitchen.placement.methods import place

    ep = episodes[0]
    with serve_process("--method", "ring") as url:
        files, fields = _request(ep, floor_points="0")
        status, doc, _ = _post(url, files, {**fields, "mount_height": "0.9"})
        assert status == 200, doc
        expected = place(
            "ring",
            np.round(ep.depth * 1000) / 1000,
            ep.intrinsics,
            ep.camera_to_base,
            ep.semantic == TARGET,
            ep.robot,
            obstacle_masks=[ep.semantic == OBSTACLE],
            mount_height=0.9,
        )
        assert doc["model"] == "ring"
        got = [(p["x"], p["y"]) for p in doc["poses"]]
        assert got == [(round(float(x), 4), round(float(y), 4)) for x, y, _ in expected.poses]
