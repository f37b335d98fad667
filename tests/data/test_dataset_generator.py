"""Generator: worker-count independence, resume after SIGKILL, config checks, bad input."""

from __future__ import annotations

import hashlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from dataset_helpers import SMALL, make_dataset

from momakitchen.cli.main import main
from momakitchen.data.generator import GenerateRequest, generate_dataset
from momakitchen.data.integrity import check_dataset
from momakitchen.data.manifest import load_manifest
from momakitchen.data.synthetic_scene import SyntheticSceneConfig, synthetic_scene_records
from momakitchen.errors import MomaError

SLOW_SCENES = SyntheticSceneConfig(
    configs_per_scene=2, episodes_per_config=3, seconds_per_scene=0.3
)
KILL_SCENES = 8

DRIVER = """
import sys
from pathlib import Path
from momakitchen.data.generator import GenerateRequest, generate_dataset
from momakitchen.data.synthetic_scene import SyntheticSceneConfig, synthetic_scene_records
cfg = SyntheticSceneConfig(configs_per_scene=2, episodes_per_config=3, seconds_per_scene=0.3)
generate_dataset(GenerateRequest(out=Path(sys.argv[1]), num_scenes=int(sys.argv[2]),
                                 workers=2), synthetic_scene_records, cfg, progress=False,
                 write_card=False)
"""


def _alive_in_group(pgid: int) -> bool:
    """A running (not zombie) process in the group (orphans may never be reaped here)."""
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[2]) == pgid and fields[0] != "Z":
            return True
    return False


def _digests(root: Path) -> dict[str, str]:
    files = [*sorted((root / "scenes").iterdir()), root / "manifest.json"]
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in files}


@pytest.mark.parametrize("victims", ["group", "parent"])
def test_sigkill_halfway_then_resume_equals_uninterrupted_run(tmp_path, victims):
    """``group``: the driver and its pool workers die mid-scene (a lost machine);
    ``parent``: only the driver dies; its pool workers must not outlive it."""
    killed = tmp_path / "killed"
    proc = subprocess.Popen(
        [sys.executable, "-c", DRIVER, str(killed), str(KILL_SCENES)],
        start_new_session=True,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    deadline = time.monotonic() + 90
    try:
        while time.monotonic() < deadline:
            done = list((killed / "scenes").glob("scene_*.h5")) if killed.exists() else []
            if len(done) >= 3:
                break
            assert proc.poll() is None, "generation ended before it could be killed"
            time.sleep(0.05)
        else:
            pytest.fail("no shards appeared within 90 s")
    finally:
        if victims == "group":
            os.killpg(proc.pid, signal.SIGKILL)
        else:
            os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
    shards = sorted((killed / "scenes").glob("scene_*.h5"))
    assert 3 <= len(shards) < KILL_SCENES
    assert not load_manifest(killed)["complete"]
    # Resume with another worker count; the reference run is uninterrupted with 1 worker.
    generate_dataset(
        GenerateRequest(out=killed, num_scenes=KILL_SCENES, workers=1),
        synthetic_scene_records,
        SLOW_SCENES,
        progress=False,
        write_card=False,
    )
    ref = tmp_path / "ref"
    generate_dataset(
        GenerateRequest(out=ref, num_scenes=KILL_SCENES, workers=1),
        synthetic_scene_records,
        SLOW_SCENES,
        progress=False,
        write_card=False,
    )
    if victims == "parent":  # orphaned workers notice and exit (within about 0.5 s)
        deadline = time.monotonic() + 10
        while _alive_in_group(proc.pid) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not _alive_in_group(proc.pid), "orphaned pool workers are still running"
    assert _digests(killed) == _digests(ref)  # same bytes, temporaries gone
    assert check_dataset(killed)["episodes"] == KILL_SCENES * 6
    # check catches a truncated shard and names it.
    victim = killed / "scenes" / "scene_000004.h5"
    victim.write_bytes(victim.read_bytes()[:-1000])
    with pytest.raises(MomaError, match=r"scene_000004\.h5"):
        check_dataset(killed)


def test_two_workers_give_the_same_bytes_as_one(tmp_path):
    make_dataset(tmp_path / "one", scenes=4, workers=1)
    make_dataset(tmp_path / "two", scenes=4, workers=2)
    assert _digests(tmp_path / "one") == _digests(tmp_path / "two")


def test_resume_skips_existing_and_grows(tmp_path):
    root = tmp_path / "ds"
    m1 = make_dataset(root, scenes=3)
    first = (root / "scenes" / "scene_000001.h5").stat().st_mtime_ns
    m2 = make_dataset(root, scenes=6)
    assert (root / "scenes" / "scene_000001.h5").stat().st_mtime_ns == first  # not rewritten
    assert m1["counts"]["total"]["scenes"] == 3 and m2["counts"]["total"]["scenes"] == 6
    assert m2["complete"] and sorted(m2["splits"]["train"] + m2["splits"]["test"]) == list(range(6))


def test_resume_with_another_config_is_refused(tmp_path):
    root = tmp_path / "ds"
    make_dataset(root, scenes=1)
    other = SyntheticSceneConfig(configs_per_scene=3, episodes_per_config=3)
    with pytest.raises(MomaError, match=r"config\.configs_per_scene"):
        make_dataset(root, scenes=2, config=other)


def test_bad_input_is_one_line_exit_2_and_keeps_data(tmp_path, capsys):
    root = tmp_path / "ds"
    make_dataset(root, scenes=2)
    before = _digests(root)
    assert main(["generate", "--synthetic", "--out", str(root), "--scenes", "0"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "--scenes: expected an integer >= 1, got '0'" in err
    # Same directory with another producer (the simulator) is refused too.
    assert main(["generate", "--out", str(root), "--scenes", "2", "--quiet"]) == 2
    assert "use another --out" in capsys.readouterr().err
    other = tmp_path / "notes"
    other.mkdir()
    (other / "thesis.tex").write_text("keep me")
    assert main(["generate", "--synthetic", "--out", str(other), "--scenes", "1"]) == 2
    assert "without a manifest.json" in capsys.readouterr().err
    assert sorted(p.name for p in other.iterdir()) == ["thesis.tex"]
    # A corrupt shard passed to stats and check: one line naming it, exit 2.
    shard = root / "scenes" / "scene_000001.h5"
    shard.write_bytes(b"\0" * 100)
    for cmd in ("stats", "check"):
        assert main([cmd, str(root)]) == 2
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and "scene_000001.h5" in err, err
    assert _digests(root)["scene_000000.h5"] == before["scene_000000.h5"]
    assert main(["check", str(tmp_path / "missing")]) == 2
    assert "does not exist" in capsys.readouterr().err


def test_ray_backend_without_ray_is_a_clear_error(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray -> ImportError
    assert (
        main(
            [
                "generate",
                "--synthetic",
                "--out",
                str(tmp_path / "r"),
                "--scenes",
                "1",
                "--backend",
                "ray",
            ]
        )
        == 2
    )
    assert "pip install 'momakitchen[ray]'" in capsys.readouterr().err
    assert not (tmp_path / "r").exists()


def test_manifest_records_config_and_counts(small_dataset):
    m = json.loads((small_dataset / "manifest.json").read_text())
    assert m["config"]["configs_per_scene"] == SMALL.configs_per_scene
    assert m["producer"].endswith("synthetic_scene_records")
    assert m["counts"]["total"]["episodes"] == 5 * 2 * 3
    assert m["counts"]["train"]["scenes"] + m["counts"]["test"]["scenes"] == 5
    assert sum(r["total"]["episodes"] for r in m["counts"]["robots"].values()) == 30
    card = (small_dataset / "README.md").read_text()
    assert "| total | 5 | 10 | 30 |" in card and (small_dataset / "example.png").stat().st_size
    assert "Robots missing from a split" in card or "Every robot appears" in card


def test_check_and_stats_commands(small_dataset, capsys):
    assert main(["check", str(small_dataset), "--quiet"]) == 0
    assert "OK: 5 shards, 30 episodes" in capsys.readouterr().out
    assert main(["stats", str(small_dataset), "--json"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert s["splits"]["total"]["episodes"] == 30 and s["bytes_per_episode"] > 0
    assert 0 <= s["splits"]["train"]["trial_success_rate"] <= 1
    assert main(["stats", str(small_dataset)]) == 0
    assert "per episode" in capsys.readouterr().out


def test_a_run_killed_before_its_first_manifest_is_continued(tmp_path):
    root = tmp_path / "ds"
    (root / "scenes").mkdir(parents=True)
    (root / ".generate.lock").touch()
    (root / "scenes" / ".tmp-123-scene_000000.h5").write_bytes(b"partial")
    m = make_dataset(root, scenes=1)
    assert m["complete"] and sorted(p.name for p in (root / "scenes").iterdir()) == [
        "scene_000000.h5"
    ]
    # The lock file is the run's own: a finished dataset holds none.
    assert not (root / ".generate.lock").exists()


def test_a_dataset_of_an_older_schema_is_recognised_as_old(tmp_path):
    """A manifest of schema 1 (labels of the earlier routine, no feasibility flags) is
    refused with both versions named, before any of its entries is read."""
    import json

    from momakitchen.data.manifest import load_manifest

    root = tmp_path / "ds"
    make_dataset(root, scenes=1)
    path = root / "manifest.json"
    data = json.loads(path.read_text())
    data["schema_version"], data["generator_version"] = 1, "0.1.0"
    for entry in data["shards"].values():  # what version 1 did not write
        del entry["feasible"], entry["covering_views"]
    path.write_text(json.dumps(data))
    with pytest.raises(MomaError, match=r"schema version 1 \(written by momakitchen 0\.1\.0\)"):
        load_manifest(root)


def test_a_split_run_makes_that_split_and_a_full_run_adds_the_rest(tmp_path):
    from momakitchen.data.manifest import scene_split

    staged, whole = tmp_path / "staged", tmp_path / "whole"
    m = make_dataset(staged, scenes=10, split="test")
    test_ids = [s for s in range(10) if scene_split(s) == "test"]
    assert len(test_ids) == 2 and m["splits"] == {"train": [], "test": test_ids}
    assert sorted(p.name for p in (staged / "scenes").iterdir()) == [
        f"scene_{s:06d}.h5" for s in test_ids
    ]
    assert m["complete"] and m["requested"]["split"] == "test"
    assert check_dataset(staged)["episodes"] == 2 * 6  # a complete test-only dataset
    # Made whole, it is the dataset one run makes, manifest included, byte for byte.
    make_dataset(staged, scenes=10)
    make_dataset(whole, scenes=10)
    assert _digests(staged) == _digests(whole)


def test_a_split_run_interrupted_counts_only_its_split_as_missing(tmp_path, capsys):
    def stop_at_five(sid, config):  # scene 5 is a test scene (ids 5-9: one of five)
        if sid == 5:
            raise KeyboardInterrupt
        return synthetic_scene_records(sid, config)

    root = tmp_path / "ds"
    with pytest.raises(KeyboardInterrupt):
        generate_dataset(
            GenerateRequest(out=root, num_scenes=10, split="test"),
            stop_at_five,
            SMALL,
            progress=False,
            write_card=False,
        )
    assert main(["check", str(root), "--quiet"]) == 2
    assert "1 of 2 requested scenes missing" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--split", "val"], "invalid choice: 'val'"),
        (
            ["--scenes", "1", "--first-scene-id", "1", "--split", "test"],
            "no test scene among ids 1..1",
        ),
    ],
)
def test_a_bad_split_request_is_one_line_exit_2(tmp_path, capsys, args, message):
    base = ["generate", "--out", str(tmp_path / "ds"), "--synthetic", "--quiet"]
    if "--scenes" not in args:
        base += ["--scenes", "5"]
    assert main([*base, *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert message in err[-1]
    assert not (tmp_path / "ds").exists()


def test_a_second_run_on_a_locked_dataset_is_refused(tmp_path):
    """While one run holds the lock another is refused; the lock goes when the run ends."""
    from momakitchen.data.generator import _locked

    root = tmp_path / "ds"
    root.mkdir()
    with _locked(root):
        assert (root / ".generate.lock").exists()
        with pytest.raises(MomaError, match="another 'momakitchen generate' is writing"):
            make_dataset(root, scenes=1)
    assert not (root / ".generate.lock").exists()
    assert make_dataset(root, scenes=1)["complete"]


@pytest.mark.slow  # two spawned workers
def test_an_interrupted_run_does_not_wait_for_its_workers(tmp_path, monkeypatch):
    """Interrupted while a worker is busy with a long scene (as `kill -INT` on the
    generating process alone does), generate stops at once: it ends the busy worker
    instead of waiting for it to finish its scene, and leaves no temporary shard."""
    from dataset_helpers import SLOW_MARKS, slow_scene_records

    marks = tmp_path / "marks"
    marks.mkdir()
    monkeypatch.setenv(SLOW_MARKS, str(marks))
    busy = marks / "busy.pid"

    def interrupt(*_args):
        deadline = time.monotonic() + 60  # a guard against a hang, not a measure
        while not busy.exists() and time.monotonic() < deadline:
            time.sleep(0.05)
        raise KeyboardInterrupt

    request = GenerateRequest(out=tmp_path / "ds", num_scenes=2, workers=2)
    # The driver is interrupted as soon as the fast scene is written and the other scene
    # has started.
    with monkeypatch.context() as mp:
        mp.setattr("momakitchen.data.generator.mf.add_shard", interrupt)
        with pytest.raises(KeyboardInterrupt):
            generate_dataset(request, slow_scene_records, SMALL, progress=False, write_card=False)
    assert busy.exists(), "no worker started the long scene"
    assert not (marks / "finished").exists(), "generate waited for the long scene"
    with pytest.raises(ProcessLookupError):
        os.kill(int(busy.read_text()), 0)  # the busy worker is gone
    assert not [p for p in (tmp_path / "ds" / "scenes").iterdir() if p.name.startswith(".")]
