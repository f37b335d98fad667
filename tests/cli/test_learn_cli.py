"""`momakitchen train` / `evaluate` on a small synthetic dataset, and their bad input."""

import json
import os
import signal
import subprocess
import time

import pytest

from cli_process import cli_process
from momakitchen.cli.main import main


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    root = tmp_path_factory.mktemp("syn") / "data"
    assert main(["generate", "--out", str(root), "--scenes", "5", "--synthetic", "--quiet"]) == 0
    return root


@pytest.fixture(scope="module")
def run(dataset, tmp_path_factory):
    out = tmp_path_factory.mktemp("runs") / "navaff"
    assert (
        main(
            [
                "train",
                "--data",
                str(dataset),
                "--model",
                "navaff",
                "--out",
                str(out),
                "--max-steps",
                "2",
                "--batch-size",
                "2",
                "--lambda-zero",
                "0.3",
                "--checkpoint-minutes",
                "5",
                "--quiet",
            ]
        )
        == 0
    )
    return out


def test_train_then_evaluate(run, dataset, tmp_path, capsys):
    assert (run / "model.safetensors").is_file() and (run / "loss_curve.png").is_file()
    saved = json.loads((run / "config.json").read_text())["train_config"]
    assert saved["max_steps"] == 2 and saved["model_config"]["lambda_zero"] == 0.3
    assert saved["checkpoint_minutes"] == 5
    report_path = tmp_path / "eval.json"
    assert (
        main(
            [
                "evaluate",
                "--data",
                str(dataset),
                "--checkpoint",
                str(run),
                "--json",
                str(report_path),
                "--quiet",
            ]
        )
        == 0
    )
    report = json.loads(report_path.read_text())
    assert report["model"] == "navaff" and report["episodes"] > 0
    assert set(report["metrics"]) >= {"rmse", "logmse", "pcc", "sim", "cos", "ciou"}
    assert "| navaff (cpu) |" in capsys.readouterr().out


def test_evaluate_defaults_to_the_bundled_model(dataset, tmp_path, capsys):
    """Without --checkpoint (or --predictions), evaluate scores the bundled model, as msr
    and robustness do, and its help says so."""
    from momakitchen.train.checkpoint import default_checkpoint

    assert main(["evaluate", "--help"]) == 0
    assert "the bundled model" in " ".join(capsys.readouterr().out.split())
    out = tmp_path / "eval.json"
    argv = ["evaluate", "--data", str(dataset), "--json", str(out), "--quiet"]
    assert main(argv) == 0
    report = json.loads(out.read_text())
    assert report["checkpoint"] == str(default_checkpoint()) and report["model"] == "bundled"


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["train", "--data", "DATA", "--model", "nonsense", "--out", "OUT"], "nonsense"),
        (["train", "--data", "MISSING", "--model", "navaff", "--out", "OUT"], "missing"),
        (
            [
                "evaluate",
                "--data",
                "DATA",
                "--checkpoint",
                "RUN",
                "--json",
                "OUT/e.json",
                "--model",
                "pointnet2",
            ],
            "pointnet2",
        ),
        (
            ["evaluate", "--data", "DATA", "--checkpoint", "OUT/none", "--json", "OUT/e.json"],
            "none",
        ),
        (
            [
                "train",
                "--data",
                "DATA",
                "--model",
                "navaff",
                "--out",
                "OUT",
                "--checkpoint-minutes",
                "-1",
            ],
            "-1",
        ),
        # Nothing to resume: refused at once, not trained from scratch.
        (
            ["train", "--data", "DATA", "--model", "navaff", "--out", "OUT/new", "--resume"],
            "nothing to resume",
        ),
        (
            ["train", "--data", "DATA", "--model", "navaff", "--out", "RUN"],
            "already holds a checkpoint; pass --resume",
        ),
    ],
)
def test_bad_input(argv, needle, dataset, run, tmp_path, capsys):
    subst = {"DATA": str(dataset), "MISSING": str(tmp_path / "missing"), "RUN": str(run)}
    argv = [subst.get(a, a).replace("OUT", str(tmp_path / "out")) for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and needle in err
    assert not (tmp_path / "out").exists()


def test_a_one_scene_dataset_says_how_to_get_a_train_split(tmp_path, capsys):
    """`generate --scenes 1` makes a test-only dataset: generate says so, and `train` says
    which --scenes gives both splits (it used to say only "has no train episodes")."""
    root = tmp_path / "one"
    argv = ["generate", "--out", str(root), "--scenes", "1", "--synthetic", "--quiet"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "note: no train scenes" in out and "--scenes 2 or more from scene 0" in out
    run = tmp_path / "run"
    assert main(["train", "--data", str(root), "--model", "navaff", "--out", str(run)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "all test scenes" in err
    assert "`momakitchen generate --scenes 2` or more from scene 0 gives both splits" in err
    assert not run.exists()
    # Two scenes from 0 are enough: the note goes away and train has episodes.
    assert main([*argv[:4], "2", *argv[5:]]) == 0
    assert "note:" not in capsys.readouterr().out
    assert main(["stats", str(root), "--json"]) == 0
    splits = json.loads(capsys.readouterr().out)["splits"]
    assert splits["train"]["episodes"] > 0 and splits["test"]["episodes"] > 0


def test_a_bad_sensor_augmentation_in_the_config_is_named(dataset, tmp_path, capsys):
    config = tmp_path / "noise.yaml"
    config.write_text("sensor_noise: true\nsensor_augmentation:\n  sensors: [sonar]\n")
    argv = ["train", "--data", str(dataset), "--model", "navaff", "--config", str(config)]
    assert main([*argv, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "unknown sensor 'sonar'" in err and "noise.yaml" in err
    assert not (tmp_path / "out").exists()


def test_a_resume_on_other_bytes_of_the_data_is_recorded(dataset, tmp_path, capsys):
    """config.json names the training shards' bytes; a run resumed on other bytes (the
    same scenes made on another machine) warns once and records from which step."""
    from momakitchen.data.manifest import load_manifest, split_checksum

    other = tmp_path / "other"
    (tmp_path / "syn.yaml").write_text("num_floor: 200\n")
    argv = ["generate", "--out", str(other), "--scenes", "5", "--synthetic", "--quiet"]
    assert main([*argv, "--config", str(tmp_path / "syn.yaml")]) == 0
    sums = [split_checksum(load_manifest(d), "train") for d in (dataset, other)]
    assert sums[0] != sums[1]
    out = tmp_path / "run"

    def train(data, steps, *resume):
        base = ["train", "--data", str(data), "--model", "pointnet2", "--out", str(out)]
        assert main([*base, "--max-steps", str(steps), "--batch-size", "2", *resume]) == 0
        return json.loads((out / "config.json").read_text())["train_data"]

    assert train(dataset, 1) == [{"from_step": 0, "shards_sha256": sums[0]}]
    capsys.readouterr()
    assert train(dataset, 2, "--resume") == [{"from_step": 0, "shards_sha256": sums[0]}]
    assert "warning" not in capsys.readouterr().err
    moved = [{"from_step": 0, "shards_sha256": sums[0]}, {"from_step": 2, "shards_sha256": sums[1]}]
    assert train(other, 3, "--resume") == moved
    err = capsys.readouterr().err
    assert f"resuming at step 2 on training shards {sums[1][:12]}" in err
    assert f"were {sums[0][:12]}" in err
    assert train(other, 4, "--resume") == moved
    assert "warning" not in capsys.readouterr().err


def test_sigterm_to_the_process_group_checkpoints_and_exits_143(dataset, tmp_path):
    """``kill -- -PGID`` (as a batch system or a terminal's Ctrl-C reaches a run and its
    DataLoader worker): the run writes a checkpoint at the step it reached, says so and
    exits 128 + 15; ``--resume`` goes on from there."""
    out = tmp_path / "run"
    argv, env = cli_process(
        *("train", "--data", str(dataset), "--model", "navaff", "--out", str(out)),
        *("--batch-size", "2", "--workers", "1", "--quiet"),
    )
    proc = subprocess.Popen(
        [*argv, "--max-steps", "100000"],
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        start_new_session=True,
    )
    log = out / "log.csv"
    deadline = time.monotonic() + 120
    while not (log.exists() and len(log.read_text().splitlines()) > 2):  # a few steps on
        assert proc.poll() is None, proc.stderr.read()
        assert time.monotonic() < deadline, "no training step in 120 s"
        time.sleep(0.2)
    os.killpg(proc.pid, signal.SIGTERM)
    stderr = proc.communicate(timeout=120)[1]
    assert proc.returncode == 128 + signal.SIGTERM, stderr
    state = json.loads((out / "trainer_state.json").read_text())["progress"]
    assert f"stopped by SIGTERM at step {state['global_step']}, checkpoint written" in stderr
    stopped_at = state["global_step"]
    assert stopped_at >= 2
    done = subprocess.run([*argv, "--resume", "--max-steps", str(stopped_at + 1)], env=env)
    assert done.returncode == 0
    state = json.loads((out / "trainer_state.json").read_text())["progress"]
    assert state["global_step"] == stopped_at + 1


def test_train_reads_several_datasets_as_one(dataset, tmp_path, capsys):
    """--data twice: the run trains on both train splits (every episode of each counted),
    records one checksum naming both, and refuses the same directory given twice."""
    import hashlib

    from momakitchen.data import EpisodeDataset
    from momakitchen.data.manifest import load_manifest, split_checksum

    other = tmp_path / "other"
    argv = ["generate", "--out", str(other), "--scenes", "5", "--synthetic", "--quiet"]
    assert main([*argv, "--first-scene-id", "500"]) == 0
    out = tmp_path / "run"
    base = ["train", "--model", "pointnet2", "--out", str(out), "--batch-size", "2"]
    capsys.readouterr()
    assert main([*base, "--data", str(dataset), "--data", str(other), "--max-steps", "1"]) == 0
    episodes = len(EpisodeDataset(dataset)) + len(EpisodeDataset(other))
    assert f"on {episodes} episodes" in capsys.readouterr().out
    sums = " ".join(split_checksum(load_manifest(d), "train") for d in (dataset, other))
    recorded = json.loads((out / "config.json").read_text())["train_data"]
    both = hashlib.sha256(sums.encode()).hexdigest()
    assert recorded == [{"from_step": 0, "shards_sha256": both}]
    again = [*base, "--data", str(dataset), "--data", f"{dataset}/", "--out", str(tmp_path / "b")]
    assert main(again) == 2
    assert f"--data '{dataset}/' is given twice" in capsys.readouterr().err
    assert not (tmp_path / "b").exists()
