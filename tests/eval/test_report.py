"""The benchmark report: tables, figures and reuse of earlier results, on a real dataset."""

from __future__ import annotations

import dataclasses
import json
import math
import shutil
from pathlib import Path

import pytest

from momakitchen.cli.main import main
from momakitchen.errors import MomaError
from momakitchen.eval.report.benchmark import BenchmarkRequest, run_benchmark
from momakitchen.eval.report.tables import (
    paired_map_table,
    paired_table,
    pooled_paired_table,
    seed_table,
)
from momakitchen.eval.stats import (
    configurations_needed,
    detectable_lead,
    mcnemar,
    mcnemar_power,
)


def _tiny(out: Path, model: str, lambda_zero: float = 0.7, seed: int = 0) -> Path:
    from momakitchen.data.synthetic import SyntheticConfig, SyntheticEpisodes
    from momakitchen.models.config import TINY_MODEL
    from momakitchen.train import train
    from momakitchen.train.config import TrainConfig

    data = SyntheticEpisodes(SyntheticConfig(num_episodes=4, num_global=256, num_floor=128))
    cfg = TrainConfig(
        model=model,
        preset="custom",
        num_global=256,
        num_floor=128,
        epochs=1,
        batch_size=2,
        progress=False,
        seed=seed,
        model_config=dataclasses.replace(TINY_MODEL, lambda_zero=lambda_zero),
    )
    train(cfg, data, None, out)
    return out


@pytest.fixture(scope="module")
def report(real_dataset, tmp_path_factory):
    runs = tmp_path_factory.mktemp("runs")
    navaff = _tiny(runs / "navaff", "navaff")
    req = BenchmarkRequest(
        data=real_dataset,
        runs=(navaff,),
        ablations=(_tiny(runs / "no-vam", "navaff-no-vam"),),
        # The main run is also the sweep's lambda = 0.7 point.
        sweep=(_tiny(runs / "lam1", "navaff", 1.0), navaff, _tiny(runs / "lam01", "navaff", 0.1)),
        out=tmp_path_factory.mktemp("bench") / "out",
        max_configs=1,
        examples=1,
        progress=False,
    )
    return req, run_benchmark(req, log=lambda _: None)


def test_report_tables_and_figures(report):
    req, result = report
    text = (req.out / "RESULTS.md").read_text()
    for section in (
        "## Methods",
        "## Ablations",
        "## Per scene",
        "## Loss weight",
        "## Confidence",
        "## Examples",
    ):
        assert section in text
    for name in (
        "qualitative.png",
        "lambda_sweep.png",
        "msr.json",
        "benchmark.json",
        "metrics/navaff.json",
        "metrics/no-vam.json",
    ):
        assert (req.out / name).stat().st_size > 0
    assert [s["lambda_zero"] for s in result["sweep"]] == [0.1, 0.7, 1.0]  # sorted by lambda
    assert "trained for 1 epoch(s)." in text  # the sweep's schedule
    assert set(result["msr"]) == {"navaff", "random", "nearest", "oracle", "ring", "reachability"}
    assert "| ring |" in text  # geometry in the table, beside the learned methods
    msr = json.loads((req.out / "msr.json").read_text())
    assert msr["configurations"] == 1
    assert "### navaff against each method" in text and "| oracle |" in text
    assert "| PCC / SIM per robot |" in text and "| PCC / SIM per target |" in text
    # The per-target map metrics cover every test episode, grouped by the manifest's targets.
    rep = json.loads((req.out / "metrics/navaff.json").read_text())
    manifest = json.loads((req.data / "manifest.json").read_text())
    test_cats = {
        t.split("/")[0]
        for e in manifest["shards"].values()
        if e["split"] == "test"
        for t in e["targets"]
    }
    assert set(rep["per_category"]) <= test_cats
    assert sum(m["episodes"] for m in rep["per_category"].values()) == rep["episodes"]
    ablation = text.split("## Ablations")[1].split("##")[0]
    assert "| navaff-no-vam |" in ablation and "+0.0000 |" in ablation  # full model row


def test_report_reuses_metrics_and_msr(report, monkeypatch, tmp_path):
    """A run's test.json (from evaluate, same dataset) and an msr JSON are not recomputed."""
    import momakitchen.eval.evaluate as evaluate_module
    import momakitchen.eval.msr as msr_module

    req, result = report
    run = req.runs[0]
    (run / "test.json").write_text((req.out / "metrics" / "navaff.json").read_text())

    def fail(*_a, **_k):
        raise AssertionError("recomputed")

    monkeypatch.setattr(evaluate_module, "evaluate", fail)
    monkeypatch.setattr(msr_module, "run_msr", fail)
    # MSR kept as one file per run plus one for the baselines, as scripts/results.sh does.
    whole = json.loads((req.out / "msr.json").read_text())
    parts = []
    baselines = ["random", "nearest", "oracle", "ring", "reachability"]
    for name, methods in (("model", ["navaff"]), ("baselines", baselines)):
        part = {**whole, "methods": {m: whole["methods"][m] for m in methods}}
        part["records"] = [
            {**r, "methods": {m: r["methods"][m] for m in methods}} for r in whole["records"]
        ]
        parts.append(tmp_path / f"{name}.json")
        parts[-1].write_text(json.dumps(part))
    out = tmp_path / "again"
    assert (
        main(
            [
                "benchmark",
                "--data",
                str(req.data),
                "--runs",
                str(run),
                "--msr",
                *map(str, parts),
                "--out",
                str(out),
                "--examples",
                "1",
                "--quiet",
            ]
        )
        == 0
    )
    again = json.loads((out / "benchmark.json").read_text())
    assert again["runs"][str(run)] == result["runs"][str(run)]
    assert again["msr"] == result["msr"]


def test_metrics_made_on_other_test_shards_are_recomputed(report, monkeypatch, tmp_path):
    """A run's test.json is reused only where its recorded test-shard checksum, if any, is
    that of the dataset's test shards (the same scenes generated on another CPU differ)."""
    import momakitchen.eval.evaluate as evaluate_module
    from momakitchen.data.manifest import load_manifest, split_checksum
    from momakitchen.eval.report.benchmark import run_metrics

    req, _ = report
    run = tmp_path / "navaff"
    shutil.copytree(req.runs[0], run)
    (run / "test.json").write_text((req.out / "metrics" / "navaff.json").read_text())
    calls = []
    monkeypatch.setattr(evaluate_module, "evaluate", lambda *a, **k: calls.append(1) or {"new": 1})

    test_shards = split_checksum(load_manifest(req.data), "test")
    (run / "test-shards.sha256").write_text(test_shards + "\n")
    assert "new" not in run_metrics(run, req.data, test_shards, tmp_path / "m1", progress=False)
    assert not calls
    (run / "test-shards.sha256").write_text("0" * 64 + "\n")
    assert run_metrics(run, req.data, test_shards, tmp_path / "m2", progress=False)["new"] == 1
    assert calls == [1]


def test_report_bad_input(report, tmp_path, capsys):
    req, _ = report
    msr = json.loads((req.out / "msr.json").read_text())
    del msr["methods"]["oracle"]
    partial = tmp_path / "partial.json"
    partial.write_text(json.dumps(msr))
    argv = [
        "benchmark",
        "--data",
        str(req.data),
        "--runs",
        str(req.runs[0]),
        "--out",
        str(tmp_path / "o"),
    ]
    assert main([*argv, "--msr", str(partial)]) == 2
    assert "oracle" in capsys.readouterr().err
    corrupt = tmp_path / "corrupt.json"
    corrupt.write_text('{"methods": ')
    assert main([*argv, "--msr", str(partial), str(corrupt)]) == 2
    assert "corrupt.json" in capsys.readouterr().err
    assert main([*argv, "--ablations", str(tmp_path / "nope")]) == 2
    assert "nope" in capsys.readouterr().err
    twin = tmp_path / "other" / req.runs[0].name  # another run of the same name
    shutil.copytree(req.runs[0], twin)
    with pytest.raises(MomaError, match="distinct names"):
        run_benchmark(
            BenchmarkRequest(
                data=req.data,
                runs=req.runs,
                out=tmp_path / "d",
                sweep=(twin,),
                msr=(req.out / "msr.json",),
            )
        )


def test_report_seeds(report, tmp_path):
    """Runs of other seeds: each model's mean and spread over its runs, read from each
    seed run's msr.json."""
    req, _ = report
    whole = json.loads((req.out / "msr.json").read_text())
    seed1 = _tiny(tmp_path / "navaff-seed1", "navaff", seed=1)
    first = whole["records"][0]["methods"]["navaff"]["outcomes"][0]
    flipped = json.loads(json.dumps(whole))  # the same configuration, the other outcome
    flipped["records"][0]["methods"]["navaff"]["outcomes"][0] = 1 - first
    (seed1 / "msr.json").write_text(json.dumps(flipped))
    base = dict(data=req.data, runs=req.runs, msr=(req.out / "msr.json",), examples=1)
    base["progress"] = False
    again = run_benchmark(
        BenchmarkRequest(**base, seeds=(seed1,), out=tmp_path / "out"), log=lambda _: None
    )
    text = (tmp_path / "out" / "RESULTS.md").read_text()
    row = next(line for line in text.splitlines() if line.startswith("| navaff | 2 |"))
    assert row.endswith("| 50.0 ± 70.7 % |")  # Top-1 of 100 % and 0 %
    pcc = [again["runs"][str(r)]["metrics"]["pcc"] for r in (req.runs[0], seed1)]
    assert pcc[0] != pcc[1]  # another seed, another model
    assert f"{sum(pcc) / 2:.4f} ± " in row
    # A seed run whose MSR covers other configurations, or of a model not compared.
    other = json.loads(json.dumps(whole))
    other["records"][0]["scene_id"] += 1
    (seed1 / "msr.json").write_text(json.dumps(other))
    with pytest.raises(MomaError, match="other configurations"):
        run_benchmark(BenchmarkRequest(**base, seeds=(seed1,), out=tmp_path / "o2"))
    ablation = req.ablations[0]
    (ablation / "msr.json").write_text(json.dumps(whole))
    with pytest.raises(MomaError, match="navaff-no-vam run, not among"):
        run_benchmark(BenchmarkRequest(**base, seeds=(ablation,), out=tmp_path / "o3"))
    with pytest.raises(MomaError, match="MSR file"):
        BenchmarkRequest(**base, seeds=(req.sweep[0],), out=tmp_path / "o4")  # no msr.json


def test_seed_tables_pool_each_models_runs():
    def rep(pcc):
        return {"metrics": {"pcc": pcc, "sim": pcc / 2, "rmse": 0.1, "ciou": 0.4}}

    lines = seed_table(
        {"a": [(rep(0.7), [1, 1, 0, 0]), (rep(0.8), [1, 0, 0, 0])], "b": [(rep(0.6), [0, 0, 0, 1])]}
    )
    assert "| a | 2 | 0.7500 ± 0.0707 | 0.3750 ± 0.0354 | 0.1000 ± 0.0000 |" in lines[2]
    assert lines[2].endswith("| 37.5 ± 17.7 % |")
    assert lines[3] == "| b | 1 | 0.6000 | 0.3000 | 0.1000 | 0.4000 | 25.0 % |"
    # Successes per configuration out of two runs: a 2, 1, 0, 0; b 0, 1, 0, 1; c 0, 0, 0, 0.
    outcomes = {"a": [[1, 1, 0, 0], [1, 0, 0, 0]], "b": [[0, 0, 0, 1], [0, 1, 0, 0]]}
    outcomes |= {"c": [[0] * 4] * 2, "d": [[0] * 4]}
    rows = pooled_paired_table(outcomes)
    assert rows[2:4] == ["| b | 1 | 1 | 1 |", "| c | 2 | 0 | 0.5 |"]  # exact p: 1, 1/2
    assert not any(r.startswith("| d") for r in rows)  # one run against two: not tested
    assert pooled_paired_table({"a": [[1]], "b": [[0], [1]]}) == []


def test_mcnemar_counts_discordant_pairs_and_tests_them_exactly():
    a = [1] * 12 + [0] * 2 + [1] * 5 + [0] * 5
    b = [0] * 12 + [1] * 2 + [1] * 5 + [0] * 5
    only_a, only_b, p = mcnemar(a, b)
    assert (only_a, only_b) == (12, 2)
    assert p == pytest.approx(2 * sum(math.comb(14, k) for k in range(3)) / 2**14)
    assert p < 0.05
    assert mcnemar([1, 0, 1], [1, 0, 1])[2] == 1.0
    assert mcnemar([1] * 3 + [0] * 2, [0] * 3 + [1] * 2)[2] > 0.5
    with pytest.raises(MomaError, match="length"):
        mcnemar([1, 0], [1])


def test_mcnemar_power_is_the_chance_that_mcnemar_finds_the_lead():
    # Brute force on 30 configurations: every way of splitting them into only-a, only-b and
    # agreeing ones, weighted by its probability, counted where mcnemar says a is ahead.
    n, discordant, lead = 30, 0.4, 0.2
    pa, pb = (discordant + lead) / 2, (discordant - lead) / 2
    expected = 0.0
    for i in range(n + 1):
        for j in range(n + 1 - i):
            a = [1] * i + [0] * j + [1] * (n - i - j)
            b = [0] * i + [1] * j + [1] * (n - i - j)
            if i > j and mcnemar(a, b)[2] < 0.05:
                ways = math.comb(n, i) * math.comb(n - i, j)
                expected += ways * pa**i * pb**j * (1 - pa - pb) ** (n - i - j)
    assert mcnemar_power(n, discordant, lead) == pytest.approx(expected, rel=1e-9)
    assert mcnemar_power(600, 0.08, 0.0) <= 0.025  # no lead: a wins only by chance
    assert mcnemar_power(600, 0.08, 0.01) < mcnemar_power(600, 0.08, 0.03)
    assert mcnemar_power(600, 0.08, 0.01) < mcnemar_power(6000, 0.08, 0.01)
    # All 5 discordant for a: p = 2 / 32 = 0.0625, not below an alpha of 0.0625; 6 are.
    assert mcnemar_power(5, 1.0, 1.0, alpha=0.0625) == 0.0
    assert mcnemar_power(6, 1.0, 1.0, alpha=0.0625) == 1.0
    with pytest.raises(MomaError, match=r"discordant 0\.1, lead 0\.2"):
        mcnemar_power(600, 0.1, 0.2)


def test_configurations_needed_and_detectable_lead_invert_mcnemar_power():
    def linear_search(discordant, lead):
        n = 1
        while mcnemar_power(n, discordant, lead) < 0.8:
            n += 1
        return n

    assert configurations_needed(1.0, 1.0, 0.8) == linear_search(1.0, 1.0) == 6
    assert configurations_needed(0.4, 0.2, 0.8) == linear_search(0.4, 0.2)
    need = configurations_needed(0.08, 0.02, 0.8)  # bisected to 1 %
    assert mcnemar_power(need, 0.08, 0.02) >= 0.8 > mcnemar_power(int(need * 0.99) - 1, 0.08, 0.02)
    lead = detectable_lead(need, 0.08, 0.8)
    assert 0.02 - 1e-3 < lead <= 0.02 + 1e-4 and mcnemar_power(need, 0.08, lead) >= 0.8
    assert math.isnan(detectable_lead(10, 0.1, 0.8))  # at most a few discordant: never found
    with pytest.raises(MomaError, match="positive lead"):
        configurations_needed(0.08, 0.0, 0.8)


def test_paired_table_gives_mcnemar_and_the_lead_it_would_find():
    def msr(outcomes):
        records = [
            {"methods": {m: {"outcomes": [o[c]]} for m, o in outcomes.items()}}
            for c in range(len(outcomes["a"]))
        ]
        return {"methods": {m: {} for m in outcomes}, "records": records}

    a = [1] * 12 + [0] * 4 + [1] * 184
    b = [0] * 12 + [1] * 4 + [1] * 184
    rows = paired_table(msr({"a": a, "b": b, "c": a}), "a")
    lead = 100 * detectable_lead(200, 16 / 200, 0.8)
    assert rows[2] == f"| b | 12 | 4 | {mcnemar(a, b)[2]:.2g} | {lead:.1f} points |"
    assert rows[3] == "| c | 0 | 0 | 1 | none |"


def test_paired_map_table_counts_scenes_where_the_first_run_is_better():
    def report(model, pcc, rmse):
        scenes = {
            str(i): {"pcc": p, "sim": p, "rmse": r, "ciou": p}
            for i, (p, r) in enumerate(zip(pcc, rmse, strict=True))
        }
        return {"model": model, "per_scene": scenes}

    ref = report("navaff", [0.8, 0.7, 0.9, 0.6, 0.75, 0.85], [0.1, 0.2, 0.1, 0.3, 0.2, 0.1])
    # worse everywhere but scene 3 on PCC; RMSE higher (worse) everywhere
    other = report("pointnet2", [0.7, 0.6, 0.8, 0.65, 0.7, 0.8], [0.2, 0.3, 0.2, 0.4, 0.3, 0.2])
    row = next(line for line in paired_map_table([ref, other]) if line.startswith("| pointnet2"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[1].startswith("5 of 6, ") and cells[3].startswith("6 of 6, ")
    assert float(cells[3].split(", ")[1]) < 0.05  # six of six scenes: exact p = 1/32
    fewer = report("votenet", [0.8] * 5, [0.1] * 5)
    with pytest.raises(MomaError, match="different scenes"):
        paired_map_table([ref, fewer])


def test_report_robustness_table(report, tmp_path):
    """`benchmark --robustness FILE`: the track's table, and McNemar's test of the models
    under each combination (two models here: the run judged twice under other names)."""
    from momakitchen.eval.robustness.track import run_robustness
    from momakitchen.eval.robustness.views import RobustnessConfig

    req, _ = report
    config = RobustnessConfig(corruptions=("clean", "combined"), max_configs=1)
    first = run_robustness(req.data, [req.runs[0]], config)
    second = json.loads(json.dumps(first))  # the same views under another model name
    second["models"] = {"other": second["models"]["navaff"]}
    for record in second["records"]:
        record["views"] = {"other": record["views"]["navaff"]}
    files = []
    for name, result in (("a", first), ("b", second)):
        files.append(tmp_path / f"{name}.json")
        files[-1].write_text(json.dumps(result))
    out = tmp_path / "bench"
    run_benchmark(
        dataclasses.replace(req, out=out, msr=(req.out / "msr.json",), robustness=tuple(files)),
        log=lambda _: None,
    )
    text = (out / "RESULTS.md").read_text()
    section = text.split("## Robustness to real sensors")[1].split("\n## ")[0]
    assert "| navaff | combined | 1 |" in section and "| other | clean | 1 |" in section
    assert "| navaff vs other | combined | 1 | 0 | 0 | 1 |" in section  # identical outcomes
    bad = tmp_path / "bad.json"
    bad.write_text("{}")
    with pytest.raises(MomaError, match="not a `momakitchen robustness` result"):
        run_benchmark(dataclasses.replace(req, out=tmp_path / "x", robustness=(bad,)))
    assert not (tmp_path / "x").exists()


def test_confidence_table_of_a_flat_map_shows_no_empty_bins():
    """A flat map ties every Top-1 affordance: its terciles hold no configuration, and
    the table says so instead of printing empty bins."""
    from momakitchen.eval.report.tables import confidence_table

    def msr(affordance, uncertainty):
        records = [
            {"methods": {"m": {"outcomes": [i % 2], "affordance": [a], "uncertainty": [u]}}}
            for i, (a, u) in enumerate(zip(affordance, uncertainty, strict=True))
        ]
        return {"records": records}

    spread = [0.01 * i for i in range(9)]
    table = confidence_table(msr([0.5] * 9, spread), "m")
    rows = [line for line in table if line.startswith("| low") or line.startswith("| mid")]
    assert len(rows) == 2 and all("no configurations" in r for r in rows), table
    assert "– (0)" not in "\n".join(table)
    both_flat = confidence_table(msr([0.5] * 9, [0.02] * 9), "m")
    assert [line.split(" |")[0] for line in both_flat if line.startswith("| ")][-1] == "| high"
    assert not any(line.startswith(("| low", "| middle")) for line in both_flat)
    assert "left out: 2" in both_flat[-1]


def test_benchmark_takes_the_bundled_model_by_name(real_dataset, tmp_path):
    """`benchmark --runs bundled` (and no run at all) is the bundled model's run, as in
    `msr` and `robustness`; another name is still a run directory to check."""
    from momakitchen.train.checkpoint import default_checkpoint

    named = BenchmarkRequest(data=real_dataset, runs=("bundled",), out=tmp_path / "a")
    assert named.runs == (default_checkpoint(),)
    alone = BenchmarkRequest(data=real_dataset, runs=(), out=tmp_path / "b")
    assert alone.runs == (default_checkpoint(),)
    with pytest.raises(MomaError, match="'bundle' is not a run directory"):
        BenchmarkRequest(data=real_dataset, runs=("bundle",), out=tmp_path / "c")
