"""The approach track's MCAP recording, read back with the MCAP project's own reader: a
scene Foxglove shows (the room, the furniture, the obstacles and the target as boxes),
every look's images with their camera's pose, the path with the base's headings, the
fused map and the outcome, each message valid against its Foxglove JSON schema. And the
top-down figure of the same run: readable at the documents' width, every mark in its
legend, a failure shown when the run has one."""

from __future__ import annotations

import base64
import io
import json
import math
from collections import defaultdict

import numpy as np
import pytest

from figure_helpers import (
    assert_axes_labelled,
    assert_legible,
    captured_figures,
    legend_labels,
)
from momakitchen.cli.main import main


def _messages(path):
    """{topic: [(schema name, schema, message)]} of an MCAP file of JSON messages."""
    from mcap.reader import make_reader

    out = defaultdict(list)
    with open(path, "rb") as f:
        for schema, channel, message in make_reader(f).iter_messages(log_time_order=True):
            assert channel.message_encoding == "json" and schema.encoding == "jsonschema"
            doc = json.loads(schema.data)
            out[channel.topic].append((schema.name, doc, json.loads(message.data)))
    return out


def _yaw(q):
    return math.atan2(2 * (q["w"] * q["z"] + q["x"] * q["y"]), 1 - 2 * (q["y"] ** 2 + q["z"] ** 2))


@pytest.fixture(scope="module")
def recordings(real_dataset, tiny_run, tmp_path_factory):
    """`approach --record 0:0 --figure` of the model (one look, then a costmap look near
    the goal) and the oracle (costmap looks only), from the near start: the recordings,
    the run's records and the figure."""
    pytest.importorskip("mcap")
    out = tmp_path_factory.mktemp("record") / "a.json"
    argv = ["approach", "--data", str(real_dataset), "--json", str(out)]
    argv += ["--checkpoint", str(tiny_run), "--method", "oracle", "--start", "near"]
    argv += ["--policy", "single", "--max-configs", "1", "--record", "0:0", "--quiet"]
    argv += ["--figure", str(out.with_name("a.png"))]
    with pytest.MonkeyPatch.context() as mp, captured_figures(mp) as figures:
        assert main(argv) == 0
    records = json.loads(out.read_text())["records"]
    files = sorted(out.with_name("a-mcap").glob("*.mcap"))
    assert len(files) == len(records) == 2
    (figure,) = figures
    return files, records, figure


def test_every_message_is_valid_against_its_foxglove_schema(recordings):
    jsonschema = pytest.importorskip("jsonschema")
    from momakitchen.eval.approach.figure import TOPICS

    for path in recordings[0]:
        for topic, messages in _messages(path).items():
            for name, schema, msg in messages:
                assert name == TOPICS[topic] == schema["title"]
                jsonschema.validate(msg, schema)
    with pytest.raises(jsonschema.ValidationError):  # the schemas say something
        jsonschema.validate({"entities": [{"cubes": [{"pose": {}}]}]}, schema_of("SceneUpdate"))


def schema_of(name):
    from momakitchen.eval.approach.figure import message_schema

    return message_schema(f"foxglove.{name}")


def test_the_scene_holds_the_room_its_furniture_obstacles_and_target(real_dataset, recordings):
    from momakitchen.data.reader import dataset_generation
    from momakitchen.scene.configuration import sample_scene

    _, gen = dataset_generation(real_dataset)
    scene = sample_scene(0, gen.scene)
    cfg = scene.configurations[0]
    for path in recordings[0]:
        updates = [m for *_, m in _messages(path)["/approach/scene"]]
        entities = {e["id"]: e for e in updates[0]["entities"]}
        room = scene.layout.room
        floor, *walls = entities["room"]["cubes"]
        assert floor["size"]["x"] == pytest.approx(room.width)
        assert floor["size"]["y"] == pytest.approx(room.depth)
        assert len(walls) == 4 and {w["size"]["z"] for w in walls} == {room.wall_height}
        units = {e for e in entities if e.startswith(("furniture/", "appliance/"))}
        assert units == {
            f"{kind}/{p.uid}"
            for p in scene.layout.furniture
            for kind in ("furniture", "appliance")
            if f"{kind}/{p.uid}" in entities
        }
        assert len(units) == len(scene.layout.furniture)
        assert {f"obstacle/{o.uid}" for o in cfg.obstacles} <= set(entities)
        for o in cfg.obstacles:  # a box where the obstacle stands, as tall as it is
            (cube,) = entities[f"obstacle/{o.uid}"]["cubes"]
            f = o.footprint()
            assert cube["pose"]["position"]["x"] == pytest.approx(f.x)
            assert cube["pose"]["position"]["y"] == pytest.approx(f.y)
            assert cube["size"]["z"] == pytest.approx(o.model.size[2])
            assert _yaw(cube["pose"]["orientation"]) == pytest.approx(o.yaw, abs=1e-6)
        (target,) = entities["target"]["cubes"]
        position = target["pose"]["position"]
        assert [position[k] for k in "xyz"] == pytest.approx(list(cfg.target.anchor))
        # At the end, the outcome where the trial ran.
        outcome = {e["id"]: e for e in updates[-1]["entities"]}["outcome"]
        assert outcome["texts"]


def test_each_look_has_its_images_and_its_camera(recordings):
    from PIL import Image

    for path, rec in zip(*recordings[:2], strict=True):
        msgs = _messages(path)
        looks = len(rec["looks"])
        assert looks >= 1
        rgb = [m for *_, m in msgs["/approach/camera/rgb"]]
        depth = [m for *_, m in msgs["/approach/camera/depth"]]
        calibration = [m for *_, m in msgs["/approach/camera/calibration"]]
        assert len(rgb) == len(depth) == len(calibration) == looks
        frames = {m["child_frame_id"] for *_, m in msgs["/approach/tf"]}
        for k, (c, d, cal) in enumerate(zip(rgb, depth, calibration, strict=True)):
            assert c["frame_id"] == d["frame_id"] == cal["frame_id"] == f"look_{k}" in frames
            image = Image.open(io.BytesIO(base64.b64decode(c["data"])))
            assert c["format"] == "png" and image.size == (cal["width"], cal["height"])
            mm = np.frombuffer(base64.b64decode(d["data"]), "<u2")
            assert d["encoding"] == "16UC1" and mm.size == d["width"] * d["height"]
            assert (d["width"], d["height"]) == image.size and d["step"] == 2 * d["width"]
            assert 300 < np.median(mm[mm > 0]) < 10_000  # millimetres of a kitchen
        # The camera looks from its height above the floor, the look's base below it.
        for *_, tf in msgs["/approach/tf"]:
            if tf["child_frame_id"].startswith("look_"):
                assert 0.5 < tf["translation"]["z"] < 2.5
        assert "base" in frames


def test_the_path_heads_as_the_base_did_and_the_outcome_is_said(recordings):
    for path, rec in zip(*recordings[:2], strict=True):
        msgs = _messages(path)
        ((*_, moved),) = msgs["/approach/path"]
        poses = moved["poses"]
        assert len(poses) == len(rec["path"]) > 2
        yaws = np.array([_yaw(p["orientation"]) for p in poses])
        quats = np.array([[p["orientation"][k] for k in "xyzw"] for p in poses])
        assert np.allclose(np.linalg.norm(quats, axis=1), 1.0)
        # The base faces the target as it drives: it turns, and no turned pose is the
        # identity; each heading points (within the odometry's drift) at the target.
        assert np.ptp(yaws) > 0.01
        turned = np.abs(yaws) > 1e-3
        assert turned.any() and (np.abs(quats[turned, 2]) > 0).all()
        xy = np.array([[p["position"]["x"], p["position"]["y"]] for p in poses])
        target = np.asarray(rec["target_odom"])
        facing = np.arctan2(*(target - xy).T[::-1])
        off = np.angle(np.exp(1j * (yaws - facing)))
        assert np.median(np.abs(off[:-1])) < math.radians(10)
        ((*_, log),) = msgs["/approach/outcome"]
        verdict = "success" if rec["success"] else f"failure: {rec['stage']}"
        assert log["message"].endswith(verdict) and log["level"] == (2 if rec["success"] else 3)
        ((*_, fused),) = msgs["/approach/fused_map"]
        assert fused["point_stride"] == 16


def test_the_figure_is_readable_and_explains_every_mark(recordings):
    fig = recordings[2]
    assert fig.get_size_inches()[0] <= 8.6 + 1e-9
    assert_legible(fig)
    assert_axes_labelled(fig)
    labels = legend_labels(fig)
    for mark in (
        "floor the base cannot use",
        "furniture, obstacle",
        "fused map",
        "successful labelled trial",
        "start",
        "true path",
        "odometry",
        "look",
        "camera's view",
        "goal",
        "final footprint: success",
        "final footprint: failure",
        "target",
    ):
        assert any(mark in label for label in labels), (mark, labels)
    (plan,) = [ax for ax in fig.axes if ax.get_label() != "<colorbar>" and ax.axison]
    # Every coloured mark of the map is on the colour bar's scale: the fused map is the
    # colour bar's own image; nothing else is drawn in a colour map.
    fused = [im for im in plan.images if im.get_cmap().name == "viridis"]
    assert len(fused) == 1 and (fused[0].norm.vmin, fused[0].norm.vmax) == (0, 1)
    assert any(ax.get_label() == "<colorbar>" for ax in fig.axes)
    for c in plan.collections:
        assert c.get_array() is None  # no other scatter coloured by value
    # The odometry's path is drawn over the true path, thinner, so both show.
    true, odom = plan.lines[0], plan.lines[1]
    assert odom.get_linestyle() == "--" and odom.get_zorder() > true.get_zorder()
    assert odom.get_linewidth() < true.get_linewidth()


def test_the_figure_shows_a_failure_when_the_run_has_one(recordings):
    from momakitchen.eval.approach.figure import figure_picks

    (model, _oracle) = recordings[1]
    result = {"config": {}, "records": []}
    # Two robots, each with a success first; the second robot fails later.
    for i, (robot, success) in enumerate((("a", 1), ("b", 1), ("b", 0), ("a", 1))):
        result["records"].append(
            {**model, "robot": robot, "config_index": i, "success": success, "stage": "x"}
        )
    picks = figure_picks(result)
    assert [(p["robot"], p["success"]) for p in picks] == [("a", 1), ("b", 0)]
    for r in result["records"]:
        r["success"] = 1
    assert all(p["success"] for p in figure_picks(result))
