"""A model from a package installed with pip, used by every command like a built-in one,
next to a predictions file (end to end on a small real dataset)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from momakitchen.cli.main import main
from plugin_helpers import on_path, pip_install

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def two_scenes(tmp_path_factory):
    """Scenes 0 (test) and 1 (train) from the simulator-backed producer, 1 configuration x
    2 views each."""
    from momakitchen.data.config import GenerationConfig, ViewConfig
    from momakitchen.data.generator import GenerateRequest, generate_dataset
    from momakitchen.generation.producer import scene_records
    from momakitchen.scene.configuration import SceneConfig

    root = tmp_path_factory.mktemp("plugin") / "ds"
    cfg = GenerationConfig(scene=SceneConfig(configs_per_scene=1), views=ViewConfig(episodes=2))
    generate_dataset(
        GenerateRequest(out=root, num_scenes=2),
        scene_records,
        cfg,
        progress=False,
        write_card=False,
    )
    return root


def test_every_command_runs_a_pip_installed_plugin(two_scenes, tmp_path, capsys):
    from PIL import Image

    from momakitchen.data.episode import SEMANTIC_CLASSES
    from momakitchen.data.shard import SceneShard
    from momakitchen.eval.predictions import write_predictions

    site = pip_install(tmp_path / "site")
    assert (site / "mk_testplugin-0.1.0.dist-info" / "entry_points.txt").is_file()
    data = ["--data", str(two_scenes)]
    run, by_path = tmp_path / "runs" / "tinyaff", tmp_path / "runs" / "by-path"
    steps = ["--epochs", "1", "--max-steps", "2", "--workers", "0", "--quiet"]
    with on_path(site):
        assert main(["train", *data, "--model", "tinyaff", "--out", str(run), *steps]) == 0
        path_name = "mk_testplugin.models:TinyAffordance"
        assert main(["train", *data, "--model", path_name, "--out", str(by_path), *steps]) == 0
        assert json.loads((by_path / "config.json").read_text())["model"] == path_name
        assert json.loads((run / "config.json").read_text())["model"] == "tinyaff"

        test_json = run / "test.json"
        assert main(["evaluate", *data, "--checkpoint", str(run), "--json", str(test_json)]) == 0
        assert json.loads(test_json.read_text())["model"] == "tinyaff"
        msr_json = tmp_path / "msr.json"
        argv = ["msr", *data, "--checkpoint", str(run), "--checkpoint", str(by_path)]
        assert main([*argv, "--json", str(msr_json), "--quiet"]) == 0
        methods = json.loads(msr_json.read_text())["methods"]
        assert list(methods) == ["tinyaff", path_name]
        assert "uncertainty" in json.loads(msr_json.read_text())["records"][0]["methods"]["tinyaff"]

        with SceneShard(two_scenes / "scenes" / "scene_000000.h5") as shard:
            ep = shard.episode(0, 1)
            labels = {
                f"0/0/{e}": shard.arrays(0, e, ("floor_label",))["floor_label"]
                for e in shard.episode_indices(0)
            }
        depth = tmp_path / "depth.png"
        Image.fromarray(np.round(ep.depth * 1000).astype(np.uint16)).save(depth)
        mask = tmp_path / "target.png"
        target = SEMANTIC_CLASSES.index("target")
        Image.fromarray(((ep.semantic == target) * 255).astype(np.uint8)).save(mask)
        np.save(tmp_path / "tf.npy", ep.camera_to_base)
        predict = ["predict", "--depth", str(depth), "--intrinsics", *map(str, ep.intrinsics)]
        predict += ["--extrinsics", str(tmp_path / "tf.npy"), "--target-mask", str(mask)]
        predict += ["--robot", ep.robot, "--checkpoint", str(run), "--out", str(tmp_path / "p")]
        assert main(predict) == 0
        prediction = json.loads((tmp_path / "p" / "prediction.json").read_text())
        assert prediction["model"] == "tinyaff" and len(prediction["poses"]) == 5

        demo = ["demo", "--checkpoint", str(by_path), "--out", str(tmp_path / "demo")]
        assert main(demo) == 0
        assert (tmp_path / "demo" / "report.png").is_file()

        # One leaderboard row per method, whichever way it came in.
        write_predictions(tmp_path / "labels.npz", labels)
        bench = ["benchmark", *data, "--runs", str(run), "--predictions"]
        bench += [str(tmp_path / "labels.npz"), "--out", str(tmp_path / "bench"), "--quiet"]
        assert main([*bench, "--examples", "1"]) == 0
    results = (tmp_path / "bench" / "RESULTS.md").read_text()
    table = results.split("## Methods")[1].split("\n\n")[1].splitlines()
    rows = [line.split(" | ")[0].strip("| ") for line in table[2:]]
    assert rows == ["tinyaff", "labels", "ring", "reachability", "random", "nearest", "oracle"]
    bench_json = json.loads((tmp_path / "bench" / "benchmark.json").read_text())
    assert bench_json["msr"]["labels"] == bench_json["msr"]["oracle"]
    assert [v["model"] for v in bench_json["predictions"].values()] == ["labels"]
    capsys.readouterr()

    # Uninstalled, the run can no longer be loaded: one line naming the model.
    assert main(["evaluate", *data, "--checkpoint", str(run), "--json", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "unknown model 'tinyaff'" in err
