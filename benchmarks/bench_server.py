"""Benchmark ``momakitchen serve``: latency of one 640x480 frame over HTTP on localhost
against ``momakitchen.predict`` in process, on the same frame and model.

Usage::

    python benchmarks/bench_server.py [--data DIR] [--requests 20] [--repeats 3]

The frame is the last view of the first test scene of ``--data`` (default: a one-scene
dataset generated into a temporary folder, a few seconds). The server runs in its own
process (``momakitchen serve --port 0`` on 127.0.0.1, the bundled model, its default
limits; with ``MOMAKITCHEN_SERVE_TOKEN`` set, both sides use it); the client
encodes depth (16-bit PNG), colour and masks (PNG) per request, as a robot's node would,
and reads the JSON answer. Reported per repetition: median and 90th percentile wall
milliseconds of the client's call (encode + POST + answer), the server's model time
(``X-Predict-Seconds``) and in-process ``predict``, each without (``mc_samples=0``) and with
the 8 MC-dropout passes, with and without the floor points in the answer; plus the
1-minute load average.
"""

from __future__ import annotations

import argparse
import io
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
import urllib.request
import uuid
from pathlib import Path

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

import numpy as np
from bench_predict import OBSTACLE, TARGET, predict_episode  # run from benchmarks/
from PIL import Image

from momakitchen.data.shard import SceneShard
from momakitchen.train.checkpoint import default_checkpoint, load_checkpoint


def one_view(data: str | None, view: int = -1):
    """A 640x480 frame: view ``view`` of the first configuration of the first scene of
    ``data`` (default: a one-scene dataset, scene 3, generated into a temporary folder)."""
    if data is None:
        from momakitchen.data.config import GenerationConfig, ViewConfig
        from momakitchen.data.generator import GenerateRequest, generate_dataset
        from momakitchen.generation.producer import scene_records
        from momakitchen.scene.configuration import SceneConfig

        data = tempfile.mkdtemp(prefix="bench-server-")
        cfg = GenerationConfig(scene=SceneConfig(configs_per_scene=1), views=ViewConfig(episodes=2))
        generate_dataset(
            GenerateRequest(out=Path(data), num_scenes=1, first_scene_id=3),
            scene_records,
            cfg,
            progress=False,
            write_card=False,
        )
    shard_path = sorted((Path(data) / "scenes").glob("scene_*.h5"))[0]
    with SceneShard(shard_path) as shard:
        return shard.episode(0, shard.episode_indices(0)[view])


def _png(array: np.ndarray) -> bytes:
    buf = io.BytesIO()
    Image.fromarray(array).save(buf, format="PNG")
    return buf.getvalue()


def _post(url: str, ep, mc: int, floor: bool) -> float:
    """One client call (encode, POST, read the answer); returns the server's model seconds."""
    files = {
        "depth": _png(np.round(ep.depth * 1000).astype(np.uint16)),
        "rgb": _png(ep.rgb),
        "target_mask": _png((ep.semantic == TARGET).astype(np.uint8) * 255),
        "obstacle_mask": _png((ep.semantic == OBSTACLE).astype(np.uint8) * 255),
    }
    fields = {
        "intrinsics": " ".join(str(float(v)) for v in ep.intrinsics),
        "camera_to_base": " ".join(str(float(v)) for v in ep.camera_to_base.ravel()),
        "robot": ep.robot,
        "mc_samples": str(mc),
        "floor_points": "1" if floor else "0",
    }
    boundary = uuid.uuid4().hex
    body = io.BytesIO()
    for name, value in [*fields.items(), *files.items()]:
        fn = f'; filename="{name}.png"' if isinstance(value, bytes) else ""
        body.write(
            f'--{boundary}\r\nContent-Disposition: form-data; name="{name}"{fn}\r\n\r\n'.encode()
        )
        body.write(value if isinstance(value, bytes) else value.encode())
        body.write(b"\r\n")
    body.write(f"--{boundary}--\r\n".encode())
    headers = {"Content-Type": f"multipart/form-data; boundary={boundary}"}
    token = os.environ.get("MOMAKITCHEN_SERVE_TOKEN")  # the server inherits it
    if token:
        headers["Authorization"] = f"Bearer {token}"
    req = urllib.request.Request(f"{url}/predict", data=body.getvalue(), headers=headers)
    with urllib.request.urlopen(req, timeout=120) as r:
        json.loads(r.read())
        return float(r.headers["X-Predict-Seconds"])


def _stats(ms: list[float]) -> str:
    return f"median {statistics.median(ms):6.1f} ms, p90 {np.percentile(ms, 90):6.1f} ms"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", default=None)
    ap.add_argument("--requests", type=int, default=20)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    ep = one_view(args.data)
    assert ep.depth.shape == (480, 640), ep.depth.shape
    run = load_checkpoint(default_checkpoint())
    code = "import sys; from momakitchen.cli.main import main; sys.exit(main())"
    proc = subprocess.Popen(
        [sys.executable, "-c", code, "serve", "--port", "0"], stdout=subprocess.PIPE, text=True
    )
    try:
        assert proc.stdout is not None
        match = re.search(r"http://[\d.]+:\d+", proc.stdout.readline())
        assert match, "the server did not start"
        url = match.group(0)
        print(f"frame 640x480, robot {ep.robot}; server {url}; load {os.getloadavg()[0]:.2f}")

        def in_process(depth: np.ndarray, mc: int) -> None:
            predict_episode(ep, run, mc, depth)

        for mc in (0, 8):
            for _ in range(2):  # warm-up
                _post(url, ep, mc, False)
                in_process(ep.depth, mc)
            for rep in range(args.repeats):
                local, http, http_floor, model = [], [], [], []
                for _ in range(args.requests):
                    t0 = time.perf_counter()
                    in_process(np.round(ep.depth * 1000) / 1000, mc)
                    local.append(1000 * (time.perf_counter() - t0))
                    t0 = time.perf_counter()
                    model.append(1000 * _post(url, ep, mc, False))
                    http.append(1000 * (time.perf_counter() - t0))
                    t0 = time.perf_counter()
                    _post(url, ep, mc, True)
                    http_floor.append(1000 * (time.perf_counter() - t0))
                print(
                    f"mc_samples={mc} run {rep + 1}: in process {_stats(local)}; "
                    f"HTTP {_stats(http)} (model {statistics.median(model):.1f} ms); "
                    f"HTTP with floor points {_stats(http_floor)}; "
                    f"load {os.getloadavg()[0]:.2f}",
                    flush=True,
                )
    finally:
        proc.terminate()
        proc.wait(10)


if __name__ == "__main__":
    main()
