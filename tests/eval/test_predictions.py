"""Predictions files: the stored labels score perfect maps and exactly the oracle's MSR;
bad files are refused naming the first bad episode; export-inputs writes plain files."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from momakitchen.data import EpisodeDataset
from momakitchen.data.manifest import load_manifest
from momakitchen.data.shard import SceneShard
from momakitchen.errors import MomaError
from momakitchen.eval.evaluate import evaluate_predictions
from momakitchen.eval.msr import RATE_KEYS, MsrConfig, run_msr
from momakitchen.eval.predictions import (
    check_predictions,
    read_predictions,
    split_episodes,
    write_predictions,
)


def _labels(root, split="test"):
    """The stored floor labels of every episode of ``split``, by episode key."""
    manifest = load_manifest(root)
    maps = {}
    for key, _ in split_episodes(manifest, split):
        sid, c, e = (int(v) for v in key.split("/"))
        with SceneShard(root / manifest["shards"][str(sid)]["file"]) as shard:
            maps[key] = shard.arrays(c, e, ("floor_label",))["floor_label"]
    return maps


@pytest.mark.parametrize("suffix", [".npz", ".h5"])
def test_labels_as_predictions_score_perfect_maps(real_dataset, tmp_path, suffix):
    labels = _labels(real_dataset)
    path = tmp_path / f"labels{suffix}"
    write_predictions(path, labels)
    assert set(read_predictions(path)) == set(labels)
    report = evaluate_predictions(path, EpisodeDataset(real_dataset, "test"))
    m = report["metrics"]
    assert report["model"] == "labels" and report["episodes"] == len(labels)
    assert m["rmse"] == m["mae"] == m["logmse"] == 0.0
    # PCC is 1 on every episode whose map is not constant (the metric counts a constant map
    # as 0: no correlation is defined there).
    varied = [np.ptp(v) > 0 for v in labels.values()]
    assert any(varied)
    assert m["pcc"] == pytest.approx(np.mean(varied), abs=1e-12)
    assert m["ciou"] == pytest.approx(np.mean([v.max() > 0 for v in labels.values()]))


def test_labels_as_predictions_score_the_oracles_msr(real_dataset, tmp_path):
    path = tmp_path / "gt.npz"
    write_predictions(path, _labels(real_dataset))
    result = run_msr(
        real_dataset, methods=["oracle"], config=MsrConfig(), predictions=[(path, "labels")]
    )
    assert list(result["methods"]) == ["labels", "oracle"]
    for key in (*RATE_KEYS, "trials"):
        assert result["methods"]["labels"][key] == result["methods"]["oracle"][key]
    for rec in result["records"]:
        ours, oracle = rec["methods"]["labels"], rec["methods"]["oracle"]
        assert ours["points"] == oracle["points"] and ours["outcomes"] == oracle["outcomes"]
        assert "uncertainty" not in ours and len(ours["affordance"]) == len(ours["points"])
    assert result["methods"]["labels"]["floor_context"] is None
    outcomes = [o for r in result["records"] for o in r["methods"]["oracle"]["outcomes"]]
    assert len(result["records"]) == 2 and sum(outcomes) > 0


def test_check_predictions_names_the_first_bad_key(tmp_path):
    expected = [("0/0/0", 3), ("0/0/1", 2), ("5/1/0", 4)]
    good = {"0/0/0": np.zeros(3), "0/0/1": np.ones(2), "5/1/0": np.full(4, 0.5), "x": np.ones(9)}
    check_predictions(good, expected, "f.npz")  # extra keys are ignored

    def bad(change, pattern):
        with pytest.raises(MomaError, match=pattern):
            check_predictions({**good, **change}, expected, "f.npz")

    bad({"0/0/1": np.ones(3)}, r"'f.npz'.*'0/0/1' has shape \(3,\).*expected \(2,\)")
    bad({"5/1/0": np.array([0.1, np.nan, 0.2, 0.3])}, r"'5/1/0' holds NaN")
    bad({"0/0/0": np.array([0.0, 1.5, 0.2])}, r"'0/0/0' holds values outside \[0, 1\].*1\.5")
    bad({"0/0/0": np.array([-0.1, 0.5, 0.2])}, r"'0/0/0' holds values outside")
    bad({"0/0/0": np.zeros((3, 1))}, r"'0/0/0' has shape \(3, 1\)")
    bad({"0/0/1": np.array(["a", "b"])}, r"'0/0/1' holds <U1 values")
    missing = {k: v for k, v in good.items() if k != "0/0/1"}
    with pytest.raises(MomaError, match=r"lacks episode '0/0/1' \(it has 2 of the 3"):
        check_predictions(missing, expected, "f.npz")


def test_commands_refuse_bad_predictions_in_one_line(real_dataset, tmp_path, capsys):
    from momakitchen.cli.main import main

    labels = _labels(real_dataset)
    keys = list(labels)
    cases = {
        "missing": (
            {k: v for k, v in labels.items() if k != keys[1]},
            f"lacks episode '{keys[1]}'",
        ),
        "short": ({**labels, keys[2]: labels[keys[2]][:-1]}, f"'{keys[2]}' has shape"),
        "nan": ({**labels, keys[0]: labels[keys[0]] * np.nan}, f"'{keys[0]}' holds NaN"),
        "range": ({**labels, keys[3]: labels[keys[3]] + 2}, f"'{keys[3]}' holds values outside"),
    }
    for name, (maps, message) in cases.items():
        path = tmp_path / f"{name}.npz"
        write_predictions(path, maps)
        for argv in (
            ["evaluate", "--data", str(real_dataset), "--json", str(tmp_path / "e.json")],
            ["msr", "--data", str(real_dataset), "--json", str(tmp_path / "m.json")],
        ):
            assert main([*argv, "--predictions", str(path), "--quiet"]) == 2
            err = capsys.readouterr().err
            assert err.count("\n") == 1 and message in err, (name, err)
    assert not (tmp_path / "e.json").exists() and not (tmp_path / "m.json").exists()
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    argv = ["evaluate", "--data", str(real_dataset), "--json", str(tmp_path / "e.json")]
    assert main([*argv, "--predictions", str(tmp_path / "junk.npz")]) == 2
    assert main([*argv, "--predictions", str(tmp_path / "none.npz")]) == 2
    err = capsys.readouterr().err
    assert "unreadable" in err and "does not exist" in err


def test_evaluate_and_msr_commands_on_a_predictions_file(real_dataset, tmp_path, capsys):
    from momakitchen.cli.main import main

    path = tmp_path / "mine.h5"
    write_predictions(path, _labels(real_dataset))
    data = ["--data", str(real_dataset)]
    assert (
        main(
            [
                "evaluate",
                *data,
                "--predictions",
                str(path),
                "--json",
                str(tmp_path / "e.json"),
                "--quiet",
            ]
        )
        == 0
    )
    report = json.loads((tmp_path / "e.json").read_text())
    assert report["model"] == "mine" and report["metrics"]["rmse"] == 0.0
    assert "mine (predictions)" in capsys.readouterr().out
    argv = [
        "msr",
        *data,
        "--predictions",
        str(path),
        "--name",
        "gt",
        "--json",
        str(tmp_path / "m.json"),
    ]
    assert main([*argv, "--max-configs", "1", "--quiet"]) == 0
    assert list(json.loads((tmp_path / "m.json").read_text())["methods"]) == ["gt"]
    assert main([*argv, "--name", "two", "--quiet"]) == 2  # one name per file
    assert (
        main(
            [
                *argv[:-4],
                "--name",
                "oracle",
                "--method",
                "oracle",
                "--json",
                str(tmp_path / "x.json"),
            ]
        )
        == 2
    )
    err = capsys.readouterr().err
    assert "one name per predictions file" in err and "already taken" in err


@pytest.mark.parametrize("suffix", [".npz", ".h5"])
def test_export_inputs_is_readable_without_momakitchen(real_dataset, tmp_path, suffix, capsys):
    from momakitchen.cli.main import main

    out = tmp_path / "sub" / f"inputs{suffix}"
    assert main(["export-inputs", "--data", str(real_dataset), "--out", str(out)]) == 0
    expected = split_episodes(load_manifest(real_dataset), "test")
    assert f"{len(expected)} test episodes" in capsys.readouterr().out
    reader = (
        "import sys, json, numpy as np\n"
        + (
            "f = np.load(sys.argv[1]); keys = f.files; get = lambda k: f[k]\n"
            if suffix == ".npz"
            else "import h5py\nf = h5py.File(sys.argv[1]); keys = []\n"
            "f.visititems(lambda n, o: keys.append(n) if isinstance(o, h5py.Dataset) else None)\n"
            "get = lambda k: f[k][()]\n"
        )
        + "eps = sorted({k.rsplit('/', 1)[0] for k in keys if k.count('/') == 3})\n"
        "shape = lambda e, k: list(get(e + '/' + k).shape)\n"
        "out = {e: [shape(e, 'floor_xyz'), shape(e, 'robot'), shape(e, 'camera_to_base'),\n"
        "           int((get(e + '/global_align') > 0).sum())] for e in eps}\n"
        "assert not any(m.startswith('momakitchen') for m in sys.modules)\n"
        "print(json.dumps(out))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", reader, str(out)], capture_output=True, text=True, check=True
    )
    got = json.loads(done.stdout)
    assert list(got) == sorted(k for k, _ in expected)
    for key, n in expected:
        floor, robot, camera, target_points = got[key]
        assert floor == [n, 3] and camera == [4, 4] and len(robot) == 1 and target_points > 0
    assert (
        main(
            ["export-inputs", "--data", str(real_dataset), "--out", str(tmp_path / "x" / "in.csv")]
        )
        == 2
    )
    assert "unknown file type '.csv'" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


def test_benchmark_gives_each_predictions_file_a_row(real_dataset, tmp_path):
    from momakitchen.eval.report.benchmark import BenchmarkRequest, run_benchmark

    labels = _labels(real_dataset)
    write_predictions(tmp_path / "labels.npz", labels)
    write_predictions(tmp_path / "flat.h5", {k: np.full(len(v), 0.5) for k, v in labels.items()})
    files = (tmp_path / "labels.npz", tmp_path / "flat.h5")
    req = BenchmarkRequest(
        real_dataset, (), tmp_path / "out", predictions=files, examples=1, progress=False
    )
    result = run_benchmark(req, log=lambda _: None)
    text = (tmp_path / "out" / "RESULTS.md").read_text()
    table = text.split("## Methods")[1].split("\n\n")[1].splitlines()[2:]
    assert [row.split(" | ")[0].strip("| ") for row in table] == [
        "labels",
        "flat",
        "ring",
        "reachability",
        "random",
        "nearest",
        "oracle",
    ]
    assert result["msr"]["labels"] == result["msr"]["oracle"]
    assert result["predictions"][str(files[0])]["metrics"]["rmse"] == 0.0
    assert result["predictions"][str(files[1])]["metrics"]["pcc"] == 0.0  # a constant map
    assert (tmp_path / "out" / "metrics" / "flat.json").is_file()
    same = BenchmarkRequest(
        real_dataset, (), tmp_path / "o2", predictions=(files[0], files[0]), progress=False
    )
    with pytest.raises(MomaError, match="distinct names"):
        run_benchmark(same, log=lambda _: None)
