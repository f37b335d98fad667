"""docs/METHODS.md's minimal server, the code as the page shows it: its /health and
/predict answer momakitchen's client, and `approach --server` drives with it, asking it
once per usable frame (the first look of a start shared by every policy)."""

from __future__ import annotations

import json
import re
import runpy
import threading
from collections import Counter
from http.server import ThreadingHTTPServer
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from figure_helpers import level_camera
from momakitchen.cli.main import main
from momakitchen.errors import MomaError

DOC = Path(__file__).resolve().parents[2] / "docs" / "METHODS.md"


def _documented_server(tmp_path):
    """The page's server code, run as a module (not as __main__: the test serves it)."""
    blocks = re.findall(r"```python\n(.*?)```", DOC.read_text(), re.S)
    (code,) = [b for b in blocks if "class Handler(BaseHTTPRequestHandler)" in b]
    path = tmp_path / "my_server.py"
    path.write_text(code)
    return runpy.run_path(str(path), run_name="my_server")


@pytest.fixture
def server(tmp_path):
    """The documented server on a free port, counting its /predict requests."""
    handler = _documented_server(tmp_path)["Handler"]
    posts = Counter()

    class Counting(handler):
        def do_POST(self):
            posts[self.path] += 1
            super().do_POST()

        def log_message(self, *args):
            pass

    httpd = ThreadingHTTPServer(("127.0.0.1", 0), Counting)
    threading.Thread(target=httpd.serve_forever, daemon=True).start()
    try:
        yield f"http://127.0.0.1:{httpd.server_address[1]}", posts
    finally:
        httpd.shutdown()
        httpd.server_close()


def _floor_frame(target_xy=(2.5, 0.2)):
    """A camera 1.2 m above a flat floor, the target mask a patch of floor around
    ``target_xy``."""
    from momakitchen.perception.sensors import Frame

    camera_to_base, intr = level_camera()
    v, u = np.mgrid[0 : intr.height, 0 : intr.width]
    rays = np.stack([(u - intr.cx) / intr.fx, (v - intr.cy) / intr.fy, np.ones(u.shape)], -1)
    down = rays @ camera_to_base[:3, :3].T
    with np.errstate(divide="ignore"):
        t = np.where(down[..., 2] < 0, -camera_to_base[2, 3] / down[..., 2], 0.0)
    xy = camera_to_base[:2, 3] + t[..., None] * down[..., :2]
    mask = (np.hypot(*(xy - target_xy).transpose(2, 0, 1)) < 0.1) & (t > 0)
    return Frame(
        depth=t.astype(np.float32),
        rgb=np.zeros((*t.shape, 3), np.uint8),
        target_mask=mask,
        obstacle_masks=(),
        intrinsics=intr,
        camera_to_base=camera_to_base,
    )


def test_the_client_gets_the_documented_servers_answer(server):
    from momakitchen.deploy.client import ServerPerceiver

    url, posts = server
    method = ServerPerceiver(url)
    assert method.name == "server:stand-60cm"
    config = SimpleNamespace(mc_samples=0, pick_radius=0.0)
    pred = method(_floor_frame(), "panda", True, config)
    assert pred.target_xyz[:2] == pytest.approx([2.5, 0.2], abs=0.02)
    (x, y, yaw) = pred.poses[0]
    assert np.hypot(x - 2.5, y - 0.2) == pytest.approx(0.6, abs=0.05)
    assert np.cos(yaw - np.arctan2(0.2 - y, 2.5 - x)) > 0.99  # facing the target
    assert len(pred.floor_xyz) == len(pred.affordance) > 1000
    # A mask without a valid depth pixel: the server's 400 is a failed look, not a stop.
    empty = _floor_frame()
    empty.target_mask[:] = False
    empty.target_mask[0, 0] = True
    empty.depth[0, 0] = 0.0
    with pytest.raises(MomaError, match="no target pixel") as failed:
        method(empty, "panda", True, config)
    assert not failed.value.fatal
    assert posts["/predict"] == 2


def test_approach_drives_with_it_asking_once_per_usable_frame(real_dataset, server, tmp_path):
    url, posts = server
    out = tmp_path / "a.json"
    argv = ["approach", "--data", str(real_dataset), "--json", str(out), "--server", url]
    argv += ["--start", "near", "--max-configs", "1", "--quiet"]
    argv += ["--policy", "single", "--policy", "relook", "--policy", "uncertain"]
    assert main(argv) == 0
    records = json.loads(out.read_text())["records"]
    assert {r["method"] for r in records} == {"server:stand-60cm"}
    assert any(look["ok"] for r in records for look in r["looks"])
    unasked = {"costmap", "beyond_range", "target_not_in_view"}
    asked = [sum(look["cause"] not in unasked for look in r["looks"]) for r in records]
    # The first look of each start is asked once for the three policies.
    first: dict[tuple, list] = {}
    for r in records:
        first.setdefault((r["scene_id"], r["config_index"], r["start"]), []).append(r["looks"][0])
    shared = sum(len(looks) - 1 for looks in first.values() if looks[0]["cause"] not in unasked)
    assert posts["/predict"] == sum(asked) - shared
    assert posts["/predict"] < sum(r["n_looks"] for r in records)
