"""The approach track: episodes driven in PyBullet, determinism, resume, outside methods
through serve's HTTP API, the command line and its bad input."""

from __future__ import annotations

import json
import threading
from http.server import BaseHTTPRequestHandler, HTTPServer

import pytest

from cli_process import serve_process
from momakitchen.cli.main import main
from momakitchen.errors import MomaError
from momakitchen.eval.approach import track as approach_track
from momakitchen.eval.approach.config import ApproachConfig
from momakitchen.eval.approach.records import json_schema
from momakitchen.eval.approach.report import pairwise, summarize
from momakitchen.eval.approach.track import run_approach

# What a run measures on the clock differs between runs; everything else may not.
CLOCKS = ("cpu_seconds", "seconds", "looks")


def _stable(records):
    out = []
    for r in records:
        r = {k: v for k, v in r.items() if k not in CLOCKS}
        out.append(r)
    return out


def test_episodes_are_deterministic_and_end_in_a_real_trial(real_dataset, tiny_run, monkeypatch):
    from momakitchen.sim.trials import TrialRunner

    outcomes = []
    run = TrialRunner.run

    def spy(self, x, y, yaw=None):
        result = run(self, x, y, yaw)
        outcomes.append(int(result.success))
        return result

    monkeypatch.setattr(TrialRunner, "run", spy)
    cfg = ApproachConfig(starts=("near",), policies=("single",), max_configs=1)
    a = run_approach(real_dataset, [tiny_run], ["oracle", "random"], config=cfg)
    tried = [r for r in a["records"] if r["final"] is not None]  # not "unreachable_goal"
    assert [r["success"] for r in tried] == outcomes  # the trial's own outcome
    assert {r["method"] for r in a["records"]} == {"navaff", "oracle", "random"}
    for r in a["records"]:
        assert r["start"] == "near" and r["start_distance"] > 1.0
        # A static map: baselines look for their costmap only (at the start and near the
        # goal); the model's first look is a prediction.
        causes = [look["cause"] for look in r["looks"]]
        if r["method"] == "navaff":
            assert causes[0] != "costmap" and set(causes[1:]) <= {"costmap"}
        else:
            assert causes and set(causes) == {"costmap"} and r["n_looks"] <= 2
        assert 0.0 <= r["spl"] <= r["success"]
        assert r["seconds"]["total"] > 0 or r["stage"] == "unreachable_goal"
        assert r["path"][0] == pytest.approx(r["start_pose"][:2], abs=1e-3)
    monkeypatch.setattr(TrialRunner, "run", run)
    b = run_approach(real_dataset, [tiny_run], ["oracle", "random"], config=cfg)
    assert _stable(a["records"]) == _stable(b["records"])
    rows = summarize(a)
    assert {(r["method"], r["policy"], r["start"]) for r in rows} == {
        ("navaff", "single", "near"),
        ("oracle", "-", "near"),
        ("random", "-", "near"),
    }
    assert len(pairwise(a)) == 3
    from momakitchen.eval.approach.records import strata

    for r, row in [(r, row) for r in a["records"] for row in rows if row["method"] == r["method"]]:
        axes = strata(r)
        assert set(axes) == {"target", "clutter", "height", "reach", "mount"}
        assert r["obstacles_near"] >= 0 and r["reach"] > 0.3 and 0 < r["target_height"] < 2.5
        for axis, value in axes.items():  # every episode counted in its stratum
            assert row["per_stratum"][axis][value]["episodes"] >= 1
    jsonschema = pytest.importorskip("jsonschema")
    schema = json_schema()
    for r in a["records"]:
        jsonschema.validate(r, schema)  # the rows are the typed records' JSON
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate({**a["records"][0], "looks": [{"ok": "yes"}]}, schema)


@pytest.mark.slow
def test_far_starts_relook_and_resume(real_dataset, tiny_run, tmp_path, monkeypatch):
    cfg = ApproachConfig(starts=("far",), policies=("single", "relook"), max_configs=2)
    resume = tmp_path / "run.partial.jsonl"
    a = run_approach(real_dataset, [tiny_run], ["oracle"], config=cfg, resume=resume)
    far = [r for r in a["records"] if r["method"] == "oracle"]
    assert far and all(r["start_distance"] >= 2.5 for r in far)
    relook = [r for r in a["records"] if r["policy"] == "relook"]
    assert any(r["n_looks"] == 2 for r in relook)  # far starts look again near the goal
    assert len(resume.read_text().splitlines()) == 1 + 2  # settings, then a line a config

    def no_work(*args, **kwargs):
        raise AssertionError("a configuration of the resume file ran again")

    monkeypatch.setattr(approach_track, "run_configuration", no_work)
    b = run_approach(real_dataset, [tiny_run], ["oracle"], config=cfg, resume=resume)
    assert b["records"] == a["records"]
    with pytest.raises(MomaError, match="other settings"):
        run_approach(
            real_dataset,
            [tiny_run],
            ["oracle"],
            config=ApproachConfig(max_configs=2),
            resume=resume,
        )


@pytest.fixture(scope="module")
def server():
    """The bundled model behind ``momakitchen serve`` (a tiny test model's flat map would
    make the pick hinge on the answer's 4-decimal rounding)."""
    with serve_process() as url:
        yield url


@pytest.mark.slow
def test_a_server_method_drives_as_the_local_model_does(real_dataset, server):
    pytest.importorskip("aiohttp")
    cfg = ApproachConfig(starts=("near",), policies=("single",), max_configs=1)
    local = run_approach(real_dataset, config=cfg)["records"]
    remote = run_approach(real_dataset, servers=[server], config=cfg)["records"]
    assert remote[0]["method"].startswith("server:")
    for a, b in zip(local, remote, strict=True):
        # The answer's numbers are rounded to 4 decimals in prediction.json: the same goal.
        assert b["goal"] == pytest.approx(a["goal"], abs=0.06)
        assert b["success"] == a["success"]


class _Garbage(BaseHTTPRequestHandler):
    def do_GET(self):  # /health answers as serve does
        body = json.dumps({"status": "ok", "model": "navaff"}).encode()
        self.send_response(200)
        self.send_header("Content-Type", "application/json")
        self.end_headers()
        self.wfile.write(body)

    def do_POST(self):
        self.rfile.read(int(self.headers["Content-Length"]))
        self.send_response(200)
        self.end_headers()
        self.wfile.write(b'{"floor_points": "not rows"}')

    def log_message(self, *args):
        pass


def test_a_server_that_answers_garbage_stops_the_run_and_keeps_what_was_done(
    real_dataset, tmp_path
):
    httpd = HTTPServer(("127.0.0.1", 0), _Garbage)
    threading.Thread(target=httpd.serve_forever, daemon=True).start()
    url = f"http://127.0.0.1:{httpd.server_address[1]}"
    out = tmp_path / "a.json"
    try:
        code = main(
            [
                "approach",
                "--data",
                str(real_dataset),
                "--json",
                str(out),
                "--server",
                url,
                "--start",
                "near",
                "--policy",
                "single",
                "--max-configs",
                "1",
                "--quiet",
            ]
        )
    finally:
        httpd.shutdown()
    assert code == 2 and not out.exists()
    assert (tmp_path / "a.json.partial.jsonl").exists()  # the resume file stays


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--start", "middle"], "unknown start 'middle'"),
        (["--policy", "often"], "unknown policy 'often'"),
        (["--perception", "x-ray"], "unknown perception preset 'x-ray'"),
        (["--stop-xy", "-1"], "stop_xy must be in [0, 0.5], got -0.01"),
        (["--method", "teleport"], "unknown method 'teleport'"),
        (["--map", "psychic"], "psychic"),
        (["--record", "999:0"], "--record 999:0 is not a configuration of this run"),
        (["--server", "http://127.0.0.1:9"], "cannot reach server"),
        (["--record", "7"], "--record wants SCENE:CONFIG"),
        (["--part", "3/2"], "expected K/N with 1 <= K <= N, got '3/2'"),
        (["--part", "9/9"], "part 9/9 is empty"),
        (
            ["--obstacle-min-points", "0"],
            "obstacle_min_points must be an integer in [1, 1000], got 0",
        ),
    ],
)
def test_bad_input_is_one_line_before_any_work(real_dataset, tmp_path, capsys, argv, message):
    out = tmp_path / "sub" / "a.json"
    code = main(["approach", "--data", str(real_dataset), "--json", str(out), *argv])
    err = capsys.readouterr().err.strip()
    assert code == 2 and message in err and "\n" not in err
    assert not out.parent.exists()


@pytest.mark.slow
def test_approach_cli_writes_tables_figure_and_recordings(real_dataset, tiny_run, tmp_path, capsys):
    from mcap.reader import make_reader

    out = tmp_path / "a.json"
    code = main(
        [
            "approach",
            "--data",
            str(real_dataset),
            "--json",
            str(out),
            "--checkpoint",
            str(tiny_run),
            "--method",
            "oracle",
            "--start",
            "near",
            "--policy",
            "single",
            "--max-configs",
            "1",
            "--stop-sweep",
            "--markdown",
            str(tmp_path / "a.md"),
            "--figure",
            str(tmp_path / "a.png"),
            "--record",
            "0:0",
            "--quiet",
        ]
    )
    assert code == 0
    result = json.loads(out.read_text())
    row = result["results"][0]
    assert {"method", "policy", "start", "episodes", "success", "spl", "looks", "seconds"} <= set(
        row
    )
    assert len(row["stop_sweep"]["success"]) == 6
    assert "| start | method (policy) |" in (tmp_path / "a.md").read_text()
    assert (tmp_path / "a.png").read_bytes()[:4] == b"\x89PNG"
    files = sorted((tmp_path / "a-mcap").glob("*.mcap"))
    assert len(files) == 2
    with open(files[0], "rb") as f:
        topics = {c.topic for _, c, _ in make_reader(f).iter_messages()}
    assert {"/approach/base", "/approach/odom", "/approach/fused_map"} <= topics
    assert not (tmp_path / "a.json.partial.jsonl").exists()
    assert "navaff (single)" in capsys.readouterr().out


def test_runs_of_other_methods_merge_into_one_result_and_csv(real_dataset, tmp_path, capsys):
    common = ["approach", "--data", str(real_dataset), "--max-configs", "1", "--quiet"]
    common += ["--policy", "single"]
    a, b, merged = tmp_path / "a.json", tmp_path / "b.json", tmp_path / "m.json"
    assert main([*common, "--json", str(a), "--method", "oracle"]) == 0
    assert main([*common, "--json", str(b), "--method", "nearest"]) == 0
    csv = tmp_path / "m.csv"
    argv = ["approach", "--merge", str(a), str(b), "--json", str(merged), "--csv", str(csv)]
    assert main(argv) == 0
    result = json.loads(merged.read_text())
    runs = [json.loads(p.read_text()) for p in (a, b)]
    assert result["records"] == runs[0]["records"] + runs[1]["records"]
    compact = tmp_path / "c.json"
    assert main([*argv[:4], "--json", str(compact), "--compact"]) == 0
    assert all("path" not in r for r in json.loads(compact.read_text())["records"])
    lines = csv.read_text().splitlines()
    assert lines[0].startswith("start,method,policy,episodes,success,spl")
    assert {line.split(",")[1] for line in lines[1:]} == {"oracle", "nearest"}
    assert any(h.startswith("stratum:target=") for h in lines[0].split(","))
    capsys.readouterr()
    assert main(["approach", "--merge", str(a), str(a), "--json", str(merged)]) == 2
    assert "repeats methods" in capsys.readouterr().err
    assert main(["approach", "--json", str(merged)]) == 2  # neither --data nor --merge
    assert "--data is required" in capsys.readouterr().err


def test_a_look_sees_the_configuration_as_labelled_after_a_trial(real_dataset):
    """A trial moves the target (lifts it, opens its door); the next episode's look must
    not see that."""
    import numpy as np

    from momakitchen.data.reader import dataset_generation, rebuilt_configurations
    from momakitchen.eval.approach.track import opened_configuration

    manifest, gen = dataset_generation(real_dataset)
    (sid,) = [int(k) for k in manifest["shards"]]
    todo = [(sid, 0, manifest["shards"][str(sid)]["file"])]
    for scene, shard, ci in rebuilt_configurations(real_dataset, todo, gen.scene):
        with opened_configuration(scene, shard, ci, gen, ApproachConfig()) as ctx:
            ok = ctx.successes
            assert len(ok), "the fixture's configuration 0 has a successful trial"
            episode = shard.episode(ci, shard.episode_indices(ci)[0])
            before = ctx.render(episode.base_pose, episode.camera_to_base)
            assert ctx.runner.run(*ok[0]).success  # the target really moved
            after = ctx.render(episode.base_pose, episode.camera_to_base)
        np.testing.assert_array_equal(after.depth, before.depth)
        np.testing.assert_array_equal(after.target_mask, before.target_mask)


def test_a_stray_depth_point_marks_no_cell_with_obstacle_min_points(real_dataset):
    """A look's obstacle points mark the costmap cell by cell; with ``obstacle_min_points``
    a cell needs that many of them, so one stray depth point blocks no stance."""
    import numpy as np

    from momakitchen.data.reader import dataset_generation, rebuilt_configurations
    from momakitchen.eval.approach.baselines import baseline_goal
    from momakitchen.eval.approach.episode import Episode
    from momakitchen.eval.approach.track import opened_configuration, placed_start

    manifest, gen = dataset_generation(real_dataset)
    (sid,) = [int(k) for k in manifest["shards"]]
    todo = [(sid, 0, manifest["shards"][str(sid)]["file"])]
    blocked = {}
    for n in (1, 5):
        config = ApproachConfig(obstacle_min_points=n)
        for scene, shard, ci in rebuilt_configurations(real_dataset, todo, gen.scene):
            with opened_configuration(scene, shard, ci, gen, config) as ctx:
                start, head = placed_start(ctx, "near", shard)
                ep = Episode(
                    ctx, start, head, 0, "oracle", "-", goal_of=baseline_goal(ctx, "oracle")
                )
                free = ctx.known.cells[ctx.known.free]
                # two free cells farther apart than a base box reaches
                stray = free[np.argmax(np.hypot(*(free - ctx.anchor[:2]).T))]
                crowd = free[np.argmax(np.hypot(*(free - stray).T))]
                # the points are given in the base frame at the start: the base is there
                x, y, yaw = ep.state.odom
                c, s = np.cos(yaw), np.sin(yaw)
                world = np.vstack([stray[None], np.repeat(crowd[None], 8, 0)])
                rel = world - [x, y]
                base = np.stack([c * rel[:, 0] + s * rel[:, 1], -s * rel[:, 0] + c * rel[:, 1]], 1)
                ep.observe(base)
                blocked[n] = [not ep.costmap.is_free(*p) for p in (stray, crowd)]
    assert blocked[1] == [True, True]  # every point marks its cell: the stray one too
    assert blocked[5] == [False, True]
    assert "obstacle_min_points" not in ApproachConfig().to_dict()  # runs before it compare equal
    assert ApproachConfig(obstacle_min_points=5).to_dict()["obstacle_min_points"] == 5
    with pytest.raises(MomaError, match="obstacle_min_points must be an integer in"):
        ApproachConfig(obstacle_min_points=0)
