"""MSR: point selection, frames, the labelling's trial, determinism and bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest

from momakitchen.errors import MomaError
from momakitchen.eval.msr import MsrConfig, format_msr_table, merge_msr, run_msr
from momakitchen.frames import base_to_world_xy, world_to_base
from momakitchen.models.inference import local_mean, select_points
from momakitchen.sim.trials import TrialRunner
from momakitchen.train.checkpoint import load_checkpoint


def test_select_points_orders_by_score_and_spreads():
    xy = np.array([[0.0, 0.0], [0.05, 0.0], [0.5, 0.0], [1.0, 0.0], [1.5, 0.0]])
    scores = np.array([0.9, 0.8, 0.7, 0.1, 0.7])
    assert select_points(xy, scores, 3, 0.2) == [0, 2, 4]  # 1 is near 0; tie: lower index
    assert select_points(xy, scores, 5, 0.0) == [0, 1, 2, 4, 3]
    assert select_points(xy, scores, 3, 0.2, accept=lambda i: i != 2) == [0, 4, 3]
    assert select_points(xy, scores, 10, 0.6) == [0, 4]  # fewer than k spread points exist


def test_local_mean_hand_values():
    xy = np.array([[0.0, 0.0], [0.05, 0.0], [1.0, 0.0], [1.0, 0.0], [3.0, 0.0]])
    values = np.array([1.0, 0.0, 3.0, 5.0, 2.0])
    # 0 and 1 are within 0.1 m of each other; 2 and 3 coincide (distance 0 counts); 4 alone.
    np.testing.assert_allclose(local_mean(xy, values, 0.1), [0.5, 0.5, 4.0, 4.0, 2.0])
    np.testing.assert_allclose(local_mean(xy, values, 1e-9), [1.0, 0.0, 4.0, 4.0, 2.0])


def test_pick_radius_prefers_a_region_to_a_lone_peak():
    # A spike at x = 0 among low points, and a plateau around x = 1 (rim 0.8, centre 0.9),
    # on a 5 cm line of floor points.
    xs = np.r_[-0.05, 0.0, 0.05, np.arange(0.8, 1.21, 0.05)]
    xy = np.stack([xs, np.zeros_like(xs)], 1)
    scores = np.r_[0.1, 1.0, 0.1, 0.8, 0.85, 0.85, 0.9, 0.9, 0.9, 0.85, 0.85, 0.8]
    assert select_points(xy, scores, 1, 0.2) == [1]
    best = select_points(xy, scores, 1, 0.2, radius=0.1)[0]
    assert xs[best] == pytest.approx(1.0, abs=0.06)  # the plateau's centre, not its rim
    # Then the plateau's rims (local means 0.825), then the spike's spot (0.4 on all three).
    assert select_points(xy, scores, 4, 0.2, radius=0.1)[1:] == [3, 11, 0]
    with pytest.raises(MomaError, match=r"pick_radius.*1\.5"):
        MsrConfig(pick_radius=1.5)


def test_base_to_world_inverts_world_to_base():
    rng = np.random.default_rng(0)
    base = (1.3, -0.4, 2.1)
    pts = rng.uniform(-3, 3, (50, 2))
    np.testing.assert_allclose(base_to_world_xy(world_to_base(pts, base), base), pts, atol=1e-12)


def test_msr_runs_the_labelling_trial(real_dataset, monkeypatch):
    """MSR outcomes are exactly what TrialRunner.run returned, the function that labelling
    (label_configuration) calls for every grid position."""
    from momakitchen.data.config import GenerationConfig
    from momakitchen.scene.configuration import sample_scene
    from momakitchen.sim.labels import label_configuration
    from momakitchen.sim.world import World

    calls: list[tuple[float, float, int]] = []
    original = TrialRunner.run

    def recording(self, x, y, yaw=None):
        result = original(self, x, y, yaw)
        calls.append((round(float(x), 4), round(float(y), 4), int(result.success)))
        return result

    monkeypatch.setattr(TrialRunner, "run", recording)
    result = run_msr(real_dataset, methods=["oracle", "nearest"], config=MsrConfig(max_configs=1))
    rec = result["records"][0]
    ran = {(x, y): ok for x, y, ok in calls}
    chosen = [
        (tuple(p), o)
        for m in rec["methods"].values()
        for p, o in zip(m["points"], m["outcomes"], strict=True)
    ]
    assert chosen and len(ran) == len({p for p, _ in chosen})  # one run per distinct point
    assert all(ran[p] == o for p, o in chosen)

    calls.clear()
    manifest = json.loads((real_dataset / "manifest.json").read_text())
    gen = GenerationConfig.from_dict(manifest["config"])
    scene = sample_scene(0, gen.scene)
    with World(scene.layout) as world:
        labels = label_configuration(world, scene.configurations[0], trial_config=gen.trial)
    assert len(calls) == len(labels.positions)
    assert [ok for *_, ok in calls] == labels.outcomes.tolist()


def test_msr_is_deterministic_and_oracle_beats_random(real_dataset, tiny_run):
    cfg = MsrConfig(seed=3)
    methods = ["oracle", "random", "nearest"]
    a = run_msr(real_dataset, [tiny_run], methods, config=cfg)
    # Run apart (one file per model, one for the baselines) and merged: the same result.
    model_only = run_msr(real_dataset, [tiny_run], config=cfg)
    baselines = run_msr(real_dataset, methods=methods, config=cfg)
    assert merge_msr([("model", model_only), ("baselines", baselines)]) == a
    assert a["configurations"] == 2
    m = a["methods"]
    assert m["navaff"]["floor_context"] == load_checkpoint(tiny_run).config.num_floor
    assert "floor_context" not in m["random"]
    assert list(m) == ["navaff", *methods]
    assert a["config"]["pick_radius"] == 0.0
    for rec in a["records"]:  # the model's own view of its chosen points
        chosen = rec["methods"]["navaff"]
        assert len(chosen["affordance"]) == len(chosen["uncertainty"]) == len(chosen["points"])
        assert chosen["affordance"] == sorted(chosen["affordance"], reverse=True)
    assert m["oracle"]["topk"] >= m["random"]["topk"]
    assert set(m["oracle"]["per_robot"]) == {r["robot"] for r in a["records"]}
    for rec in a["records"]:
        for method in rec["methods"].values():
            assert len(method["points"]) <= 5
            pts = np.array(method["points"]).reshape(-1, 2)
            d = np.hypot(*(pts[:, None] - pts[None]).transpose(2, 0, 1))
            assert (d[np.triu_indices(len(pts), 1)] >= 0.2 - 1e-3).all()


def test_msr_bad_input(real_dataset, tmp_path):
    from momakitchen.data.generator import GenerateRequest, generate_dataset
    from momakitchen.data.synthetic_scene import SyntheticSceneConfig, synthetic_scene_records

    with pytest.raises(MomaError, match="unknown MSR method 'best'"):
        run_msr(real_dataset, methods=["best"])
    bundled = run_msr(real_dataset, config=MsrConfig(max_configs=1))  # default: bundled model
    assert list(bundled["methods"]) == ["bundled"]  # named apart from any NavAff run
    with pytest.raises(MomaError, match="does not exist"):
        run_msr(tmp_path / "nope", methods=["oracle"])
    synthetic = tmp_path / "synthetic"
    generate_dataset(
        GenerateRequest(out=synthetic, num_scenes=1),
        synthetic_scene_records,
        SyntheticSceneConfig(),
        progress=False,
        write_card=False,
    )
    with pytest.raises(MomaError, match="rebuild its worlds"):
        run_msr(synthetic, methods=["oracle"])
    with pytest.raises(MomaError, match="top_k"):
        MsrConfig(top_k=0)


def test_msr_cli(real_dataset, tmp_path, capsys):
    from momakitchen.cli.main import main

    out = tmp_path / "msr.json"
    assert (
        main(
            [
                "msr",
                "--data",
                str(real_dataset),
                "--method",
                "random",
                "--json",
                str(out),
                "--max-configs",
                "1",
                "--quiet",
            ]
        )
        == 0
    )
    assert json.loads(out.read_text())["methods"]["random"]["trials"] >= 1
    assert "Top-1 MSR" in capsys.readouterr().out
    assert (
        main(
            [
                "msr",
                "--data",
                str(real_dataset),
                "--checkpoint",
                str(tmp_path / "none"),
                "--json",
                str(out),
            ]
        )
        == 2
    )
    assert main(["msr", "--data", str(real_dataset), "--method", "best", "--json", str(out)]) == 2
    assert "unknown MSR method" in capsys.readouterr().err


def test_a_checkpoint_can_be_reported_by_another_name(real_dataset, tiny_run, tmp_path):
    from momakitchen.cli.main import main
    from momakitchen.cli.msr import _named_checkpoint

    cfg = MsrConfig(max_configs=1)
    plain = run_msr(real_dataset, [tiny_run], config=cfg)
    named = run_msr(real_dataset, [(tiny_run, "navaff:mine")], config=cfg)
    assert list(named["methods"]) == ["navaff:mine"]
    assert named["methods"]["navaff:mine"]["top1"] == plain["methods"]["navaff"]["top1"]
    with pytest.raises(MomaError, match="would be reported as 'oracle'"):
        run_msr(real_dataset, [(tiny_run, "oracle")], ["oracle"], config=cfg)
    with pytest.raises(MomaError, match="would be reported as 'navaff'"):
        run_msr(real_dataset, [tiny_run, (tiny_run, "navaff")], config=cfg)
    assert _named_checkpoint("mine=runs/a") == ("runs/a", "mine")
    assert _named_checkpoint(str(tiny_run)) == str(tiny_run)
    odd = tmp_path / "a=b"
    odd.mkdir()
    assert _named_checkpoint(str(odd)) == str(odd)  # an existing path stays a path
    out = tmp_path / "m.json"
    argv = ["msr", "--data", str(real_dataset), "--json", str(out), "--max-configs", "1"]
    assert main([*argv, "--checkpoint", "=nowhere", "--quiet"]) == 2
    assert main([*argv, "--checkpoint", f"navaff:mine={tiny_run}", "--quiet"]) == 0
    assert json.loads(out.read_text())["methods"] == named["methods"]
    assert main([*argv, "--checkpoint", f"mine={tmp_path / 'none'}", "--quiet"]) == 2


def test_msr_checks_every_shard_before_the_first_configuration(
    real_dataset, tmp_path, monkeypatch, capsys
):
    """A second test scene whose shard is truncated is refused before any configuration
    runs (it used to be found after the first scene's configurations, in HDF5's words)."""
    import shutil

    import momakitchen.eval.msr as msr_module
    from momakitchen.cli.main import main

    root = tmp_path / "ds"
    shutil.copytree(real_dataset, root)
    manifest = json.loads((root / "manifest.json").read_text())
    entry = {**manifest["shards"]["0"], "scene_id": 5, "file": "scenes/scene_000005.h5"}
    manifest["shards"]["5"] = entry  # scene 5 is a test scene, after scene 0
    manifest["splits"]["test"].append(5)
    (root / "manifest.json").write_text(json.dumps(manifest))
    data = (root / "scenes" / "scene_000000.h5").read_bytes()
    (root / "scenes" / "scene_000005.h5").write_bytes(data[: len(data) // 2])
    calls = []
    monkeypatch.setattr(msr_module, "run_configuration", lambda *a, **k: calls.append(a))
    argv = ["msr", "--data", str(root), "--method", "random", "--json", str(tmp_path / "m.json")]
    assert main([*argv, "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "scene_000005.h5" in err and "truncated" in err
    assert "Unable to" not in err and "HDF5" not in err
    assert calls == [] and not (tmp_path / "m.json").exists()


def test_merge_msr_refuses_parts_that_do_not_fit():
    def part(methods, seed=0, scenes=(1, 2), **settings):
        recs = [
            {
                "scene_id": sid,
                "config_index": 0,
                "episode_index": 3,
                "robot": "panda",
                "target": "mug",
                "feasible": True,
                "methods": {m: {"outcomes": [1]} for m in methods},
            }
            for sid in scenes
        ]
        return {
            "dataset": "/d",
            "config": {"seed": seed, **settings},
            "configurations": len(recs),
            "methods": {m: {"top1": 1.0} for m in methods},
            "records": recs,
        }

    merged = merge_msr([("a", part(["navaff"])), ("b", part(["oracle", "random"]))])
    assert list(merged["methods"]) == ["navaff", "oracle", "random"]
    assert all(set(r["methods"]) == {"navaff", "oracle", "random"} for r in merged["records"])
    # A file from before the pick radius existed ranked by the raw map: radius 0.
    old = merge_msr([("a", part(["navaff"])), ("b", part(["oracle"], pick_radius=0.0))])
    assert old["config"] == {"seed": 0, "pick_radius": 0.0}
    for parts, message in (
        ([("a", part(["navaff"])), ("b", part(["oracle"], seed=1))], "settings of 'b'"),
        ([("a", part(["navaff"])), ("b", part(["oracle"], pick_radius=0.1))], "settings of"),
        ([("a", part(["navaff"])), ("b", {**part(["oracle"]), "config": 3})], "not a `mom"),
        ([("a", part(["navaff"])), ("b", part(["oracle"], scenes=(1, 3)))], "different config"),
        ([("a", part(["navaff"])), ("b", part(["navaff", "oracle"]))], r"\['navaff'\]"),
        ([("a", part(["navaff"])), ("b", [])], "'b' is not a `momakitchen msr` result"),
        ([("a", part(["navaff"])), ("b", {**part(["oracle"]), "records": [{}]})], "malformed"),
    ):
        with pytest.raises(MomaError, match=message):
            merge_msr(parts)


def test_msr_table_shows_top_k_columns_only_when_k_exceeds_one():
    rates = {"top1": 0.5, "topk": 0.25, "top1_feasible": 0.75, "topk_feasible": 0.125}
    result = {
        "config": {"top_k": 5, "split": "test"},
        "configurations": 4,
        "feasible_configurations": 3,
        "methods": {"navaff": {**rates, "trials": 20}},
    }
    head, _, row, _ = format_msr_table(result).splitlines()
    columns = "method Top-1 MSR Top-5 MSR Top-1 (feasible) Top-5 (feasible) trials"
    assert head.split() == columns.split()
    assert row.split() == ["navaff", "50.0", "%", "25.0", "%", "75.0", "%", "12.5", "%", "20"]
    result["config"]["top_k"] = 1
    head, _, row, _ = format_msr_table(result).splitlines()
    assert head.split() == "method Top-1 MSR Top-1 (feasible) trials".split()
    assert row.split() == ["navaff", "50.0", "%", "75.0", "%", "20"]
