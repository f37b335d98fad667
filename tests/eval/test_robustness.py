"""The robustness track: msr's views, as msr scores them (clean) and corrupted through the
real-robot path, tried in physics; the CLI, its files and its bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest

from momakitchen.errors import MomaError
from momakitchen.eval.robustness.tables import format_robustness_table, summarize
from momakitchen.eval.robustness.track import run_robustness
from momakitchen.eval.robustness.views import RobustnessConfig


def test_robustness_runs_msr_views_through_the_robot_path(real_dataset, tiny_run):
    from momakitchen.eval.msr import MsrConfig, run_msr

    names = ("clean", "kinect", "pitch+2", "erode5")
    config = RobustnessConfig(corruptions=names, top_k=2)
    maps: dict = {}
    result = run_robustness(real_dataset, [tiny_run], config, view_maps=maps)
    again = run_robustness(real_dataset, [tiny_run], config)
    assert result["records"] == again["records"]  # the same corruptions every run
    msr = run_msr(real_dataset, [tiny_run], config=MsrConfig(top_k=1))
    assert [r["episode_index"] for r in result["records"]] == [
        r["episode_index"] for r in msr["records"]
    ]
    assert result["configurations"] == 2 and set(maps) == set(names)
    for record in result["records"]:
        for name in names:
            view = record["views"]["navaff"][name]
            assert view["status"] in ("ok", "error", "beyond_range")
            if view["status"] == "ok":
                # a trial ran in physics at each pick: a stage code, success only if 0
                assert len(view["outcomes"]) == len(view["stages"]) >= 1
                assert all(
                    o == (s == 0) for o, s in zip(view["outcomes"], view["stages"], strict=True)
                )
                assert -1 <= view["pcc"] <= 1 and 0 <= view["sim"] <= 1
        # a 2 deg pitch is found back by the floor fit
        pitched = record["views"]["navaff"]["pitch+2"]
        assert pitched["status"] == "ok"
        assert abs(pitched["correction"]["pitch_deg"]) == pytest.approx(2.0, abs=0.3)
        assert record["views"]["navaff"]["clean"]["correction"] is None  # msr's stored view
    summary = result["models"]["navaff"]["kinect"]
    assert summary["views"] == 2 and 0 <= summary["top1"] <= 1
    table = format_robustness_table(result)
    assert "kinect" in table and "Top-2" in table


def test_the_clean_row_is_msrs_figure_on_the_same_views(real_dataset, tiny_run, tmp_path):
    """The clean row scores msr's view as msr does (the stored clouds, the same settings):
    the same points tried, the same outcomes, the same Top-1; for a model and for a
    predictions file (the stored labels, i.e. msr's oracle)."""
    from momakitchen.data.shard import SceneShard
    from momakitchen.eval.msr import MsrConfig, run_msr
    from momakitchen.eval.predictions import write_predictions

    msr = run_msr(real_dataset, [tiny_run], ["oracle"], MsrConfig(top_k=1))
    labels = {}
    for r in msr["records"]:
        with SceneShard(next((real_dataset / "scenes").iterdir())) as shard:
            ep = shard.episode(r["config_index"], r["episode_index"])
        labels[f"clean/{r['scene_id']}/{r['config_index']}/{r['episode_index']}"] = ep.floor_label
    write_predictions(tmp_path / "oracle.npz", labels)
    result = run_robustness(
        real_dataset,
        [tiny_run],
        RobustnessConfig(top_k=1),
        predictions=[(tmp_path / "oracle.npz", None)],
    )
    assert len(result["records"]) == len(msr["records"]) == 2
    for rob, ref in zip(result["records"], msr["records"], strict=True):
        assert rob["episode_index"] == ref["episode_index"]
        for name in ("navaff", "oracle"):
            view, picked = rob["views"][name]["clean"], ref["methods"][name]
            assert view["points"] == picked["points"] and view["outcomes"] == picked["outcomes"]
        assert rob["views"]["oracle"]["clean"]["pcc"] == 1.0  # the labels against themselves
    for name in ("navaff", "oracle"):
        assert result["models"][name]["clean"]["top1"] == round(msr["methods"][name]["top1"], 4)
    assert result["models"]["oracle"]["clean"]["top1"] > 0  # not a tie of two failures


def test_summary_counts_range_apart_and_errors_as_failures():
    records = [
        {
            "feasible": True,
            "views": {"m": {"x": {"status": "ok", "outcomes": [1, 0], "pcc": 0.5, "sim": 0.4}}},
        },
        {"feasible": True, "views": {"m": {"x": {"status": "error", "cause": "empty_mask"}}}},
        {"feasible": False, "views": {"m": {"x": {"status": "beyond_range"}}}},
    ]
    s = summarize(records, "m", "x")
    assert s["views"] == 3 and s["beyond_range"] == 1
    assert s["errors"] == {"empty_mask": 1}
    assert s["top1"] == 0.5 and s["topk"] == 0.25 and s["pcc"] == 0.5


def test_error_causes_are_set_where_raised_not_read_from_messages(real_dataset, monkeypatch):
    """Every message reworded: the causes a track counts stay the same."""
    from momakitchen.data.shard import SceneShard
    from momakitchen.perception.camera import Intrinsics
    from momakitchen.perception.live import frame_inputs

    init = MomaError.__init__

    def reworded(self, message="", **kw):
        init(self, "reworded", **kw)

    monkeypatch.setattr(MomaError, "__init__", reworded)
    (path,) = sorted((real_dataset / "scenes").glob("*.h5"))
    with SceneShard(path) as shard:
        ep = shard.episode(0, shard.episode_indices(0)[0])
    intr = Intrinsics(*(float(v) for v in ep.intrinsics), *ep.depth.shape[::-1])
    mask = ep.semantic == 1  # the target's class
    assert mask.any()
    depth = ep.depth.copy()
    no_depth = depth.copy()
    no_depth[mask] = 0.0
    raised = np.array(ep.camera_to_base, np.float64)
    raised[2, 3] += 1.0  # the floor where no calibration puts it
    cases = {
        "empty_mask": (depth, np.zeros_like(mask), ep.camera_to_base, None),
        "no_target_depth": (no_depth, mask, ep.camera_to_base, None),
        "target_range": (depth, mask, ep.camera_to_base, 0.2),
        "no_floor": (depth, mask, raised, None),
    }
    for cause, (d, m, tf, max_depth) in cases.items():
        with pytest.raises(MomaError, match=r"^reworded$") as info:
            frame_inputs(d, d > 0, ep.rgb, m, [], intr, tf, max_depth=max_depth)
        assert info.value.cause == cause
    assert MomaError("anything").cause == "other" and not MomaError("x").fatal


def test_bad_config():
    with pytest.raises(MomaError, match="unknown corruption 'fog'"):
        RobustnessConfig(corruptions=("clean", "fog"))
    with pytest.raises(MomaError, match="named twice"):
        RobustnessConfig(corruptions=("clean", "clean"))
    with pytest.raises(MomaError, match="top_k"):
        RobustnessConfig(top_k=0)


def test_robustness_cli(real_dataset, tiny_run, tmp_path, capsys):
    from momakitchen.cli.main import main

    assert main(["robustness", "--list"]) == 0
    listed = capsys.readouterr().out
    assert "d435" in listed and "mono" in listed and "combined" in listed
    # --data, --json and --out are required, and --help says so (--list needs none)
    assert main(["robustness", "--help"]) == 0
    usage = capsys.readouterr().out.split("\n\n")[0]
    for option in ("--data DATA", "--json JSON", "--out OUT"):
        assert option in usage and f"[{option}" not in usage, usage
    assert main(["robustness", "--data", str(real_dataset), "--json", "x.json"]) == 2
    assert "required: --out" in capsys.readouterr().err
    out = tmp_path / "rb"
    code = main(
        [
            "robustness",
            "--data",
            str(real_dataset),
            "--checkpoint",
            str(tiny_run),
            "--corruption",
            "d435",
            "--max-configs",
            "1",
            "--json",
            str(tmp_path / "r.json"),
            "--out",
            str(out),
            "--quiet",
        ]
    )
    assert code == 0
    result = json.loads((tmp_path / "r.json").read_text())
    assert result["config"]["corruptions"] == ["clean", "d435"]
    assert (out / "robustness.png").stat().st_size > 10_000
    assert "d435" in (out / "robustness.md").read_text()
    # bad input: one line, status 2, nothing written
    for args, message in [
        (["--corruption", "fog"], "unknown corruption 'fog'"),
        (["--data", str(tmp_path / "none")], "does not exist"),
    ]:
        base = [
            "robustness",
            "--data",
            str(real_dataset),
            "--json",
            str(tmp_path / "b.json"),
            "--out",
            str(tmp_path / "b"),
        ]
        assert main(base + args) == 2
        err = capsys.readouterr().err.strip()
        assert message in err and len(err.splitlines()) == 1
        assert not (tmp_path / "b.json").exists() and not (tmp_path / "b").exists()


def test_noisy_training_samples_keep_their_labels_where_the_robot_would_stand(real_dataset):
    from momakitchen.data import EpisodeDataset
    from momakitchen.perception.sensors import SensorAugmentation

    clean = EpisodeDataset(real_dataset, "all")
    noisy = EpisodeDataset(real_dataset, "all")
    noisy.use_sensor_noise(SensorAugmentation(p_ideal=0.0, sensors=("kinect",)))
    a, b = clean[0], noisy[0]
    assert not np.array_equal(a["global_xyz"].numpy(), b["global_xyz"].numpy())
    assert (b["floor_xyz"][:, 2] == 0).all()  # the floor on its fitted plane
    # labels are those of the nearest stored floor point
    from scipy.spatial import cKDTree

    d, i = cKDTree(a["floor_xyz"][:, :2].numpy()).query(b["floor_xyz"][:, :2].numpy())
    assert d.max() <= 0.08
    np.testing.assert_array_equal(b["floor_label"].numpy(), a["floor_label"].numpy()[i])
    # the same epoch draws the same noise; another epoch another
    np.testing.assert_array_equal(noisy[0]["global_xyz"], b["global_xyz"])
    noisy.set_epoch(1)
    assert not np.array_equal(noisy[0]["global_xyz"].numpy(), b["global_xyz"].numpy())


def test_a_target_beyond_the_sensors_range_is_counted_apart():
    from momakitchen.eval.robustness.views import run_view
    from momakitchen.perception.camera import Intrinsics
    from momakitchen.perception.sensors import Frame, target_range

    depth = np.full((48, 64), 4.5, np.float32)  # beyond the Kinect's 4 m, within D435's
    mask = np.zeros((48, 64), bool)
    mask[10:14, 30:34] = True
    frame = Frame(
        depth,
        np.zeros((48, 64, 3), np.uint8),
        mask,
        (),
        Intrinsics(60.0, 60.0, 32.0, 24.0, 64, 48),
        np.eye(4),
    )
    assert target_range(frame) == pytest.approx(4.5)
    view = run_view(
        None,
        frame,
        "kinect",
        (0, 0, 0),
        "panda",
        np.zeros(4, np.float32),
        RobustnessConfig(corruptions=("kinect",)),
    )
    assert view == {"status": "beyond_range", "target_range": 4.5}


def _score_exported(inputs_file, run_dir, out):
    """Score every ok view of a robustness inputs file with the run, reading nothing but
    the file (as a method running elsewhere would), and write its predictions file."""
    from momakitchen.eval.predictions import write_predictions
    from momakitchen.models.inference import predict_map
    from momakitchen.perception.live import FrameClouds
    from momakitchen.train.checkpoint import load_checkpoint

    run = load_checkpoint(run_dir)
    maps = {}
    with np.load(inputs_file) as f:
        views = sorted({k.rsplit("/", 1)[0] for k in f.files if k.count("/") == 4})
        for key in views:
            if str(f[f"{key}/status"]) != "ok":
                continue
            clouds = FrameClouds(
                *(f[f"{key}/{n}"] for n in ("global_xyz", "global_rgb", "global_align")),
                floor_xyz=f[f"{key}/floor_xyz"],
                target_xyz=f[f"{key}/target_xyz"],
                correction=None,
            )
            robot = str(f[f"{key}/robot_name"])
            # clean is the stored episode, down-sampled as msr does (seeded by its ids)
            clean = key.startswith("clean/")
            ids = tuple(int(v) for v in key.split("/")[1:]) if clean else None
            pred = predict_map(
                run,
                clouds,
                robot,
                f[f"{key}/robot"],
                top_k=1,
                mc_samples=0,
                episode_id=ids,
                threads=None if clean else 1,
            )
            maps[key] = pred.affordance
    write_predictions(out, maps)
    return maps


def test_a_method_that_runs_elsewhere_gets_the_same_views_and_figures(
    real_dataset, tiny_run, tmp_path
):
    """The exported corrupted inputs are exactly what a model is given: the model's own
    maps of them, as a predictions file, score the same trials and metrics as the model."""
    from momakitchen.eval.robustness.export import export_robustness_inputs

    config = RobustnessConfig(corruptions=("clean", "kinect", "pitch+2"), top_k=2)
    inputs = tmp_path / "inputs.npz"
    counts = export_robustness_inputs(real_dataset, inputs, config)
    assert sum(counts.values()) == 2 * 3 and counts.get("ok", 0) >= 4
    with np.load(inputs) as f:
        assert str(f["format"]) == "momakitchen-robustness-inputs-1"
        assert list(f["corruptions"]) == list(config.corruptions)
        pitched = [k for k in f.files if k.startswith("pitch+2/") and k.endswith("_correction")]
        assert pitched
        for key in pitched:  # the floor fit undid the pitch before the points were written
            assert not np.allclose(f[key], np.eye(4))
    maps = _score_exported(inputs, tiny_run, tmp_path / "mine.npz")
    assert len(maps) == counts["ok"]
    result = run_robustness(
        real_dataset, [tiny_run], config, predictions=[(tmp_path / "mine.npz", None)]
    )
    assert set(result["models"]) == {"navaff", "mine"}
    for record in result["records"]:
        model, method = record["views"]["navaff"], record["views"]["mine"]
        for name in config.corruptions:
            assert model[name] == method[name]
    assert result["models"]["navaff"] == result["models"]["mine"]


def test_robustness_predictions_cli_and_bad_files(real_dataset, tiny_run, tmp_path, capsys):
    from momakitchen.cli.main import main
    from momakitchen.eval.predictions import write_predictions

    inputs = tmp_path / "inputs.h5"
    common = ["--data", str(real_dataset), "--max-configs", "1", "--quiet"]
    argv = ["export-inputs", "--robustness", "--corruption", "d435", "--out", str(inputs)]
    assert main(argv + common) == 0
    assert "views x corruptions" in capsys.readouterr().out
    maps = _score_exported_h5(inputs, tiny_run, tmp_path / "mine.npz")
    out = tmp_path / "rb"
    argv = ["robustness", "--predictions", str(tmp_path / "mine.npz"), "--name", "mine"]
    argv += ["--corruption", "d435", "--json", str(tmp_path / "r.json"), "--out", str(out)]
    assert main(argv + common) == 0
    result = json.loads((tmp_path / "r.json").read_text())
    assert list(result["models"]) == ["mine"]  # no bundled model when a method is given
    assert (out / "robustness.png").exists()
    # bad input: one line naming the bad value, status 2, nothing written
    short = {k: v[:-1] for k, v in maps.items()}
    write_predictions(tmp_path / "short.npz", short)
    write_predictions(tmp_path / "clean-only.npz", {k: v for k, v in maps.items() if "clean/" in k})
    nan = {k: np.full_like(v, np.nan) for k, v in maps.items()}
    write_predictions(tmp_path / "nan.npz", nan)
    for file, extra, message in [
        ("short.npz", [], "floor points"),
        ("clean-only.npz", [], "no maps for corruption 'd435'"),
        ("nan.npz", [], "NaN"),
        ("none.npz", [], "does not exist"),
        ("mine.npz", ["--name", "a", "--name", "b"], "2 --name for 1 --predictions"),
    ]:
        bad = ["robustness", "--predictions", str(tmp_path / file), "--corruption", "d435"]
        bad += ["--json", str(tmp_path / "b.json"), "--out", str(tmp_path / "b"), *extra]
        assert main(bad + common) == 2, file
        err = capsys.readouterr().err.strip()
        assert message in err and len(err.splitlines()) == 1, err
        assert not (tmp_path / "b.json").exists() and not (tmp_path / "b").exists()
    plain = ["export-inputs", "--corruption", "d435", "--out", str(tmp_path / "x.npz")]
    assert main([*plain, "--data", str(real_dataset)]) == 2
    assert "need --robustness" in capsys.readouterr().err


def _score_exported_h5(inputs_file, run_dir, out):
    """:func:`_score_exported` for an HDF5 inputs file (read with h5py alone)."""
    import h5py

    npz = inputs_file.with_suffix(".npz")
    with h5py.File(inputs_file, "r") as f:
        arrays = {}

        def visit(name, obj):
            if isinstance(obj, h5py.Dataset):
                value = obj[()]
                arrays[name] = value.decode() if isinstance(value, bytes) else value

        f.visititems(visit)
    np.savez(npz, **arrays)
    return _score_exported(npz, run_dir, out)
