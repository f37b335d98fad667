"""What the repository tracks: weights only where they belong.

A weights file in git is either the bundled model (``src/momakitchen/checkpoints/<name>/
model.safetensors``, beside its ``config.json`` and ``CARD.md``) or an archived run's final
checkpoint (``results/runs/<run>/model.safetensors``, beside its ``config.json`` and the
reports or training log that show it finished its schedule). No resume state
(``trainer_state.*``), no snapshot of an unfinished run (``results/partial/``), no pickled
weights; ``.gitignore`` keeps them out.
"""

from __future__ import annotations

import csv
import functools
import json
import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
WEIGHTS = (".safetensors", ".pt", ".pth", ".ckpt", ".pkl", ".pickle", ".onnx")
BUNDLED = re.compile(r"src/momakitchen/checkpoints/[^/]+/model\.safetensors")
ARCHIVED = re.compile(r"results/runs/[^/]+/model\.safetensors")
MAX_BYTES = 4_000_000  # the largest model today is 1.7 MB


def _git(*args: str) -> str:
    try:
        out = subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True, check=True)
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout")
    return out.stdout


@functools.cache
def _tracked() -> frozenset[str]:
    return frozenset(p for p in _git("ls-files", "-z").split("\0") if p)


def _finished(run: Path, tracked: frozenset[str]) -> bool:
    """Scored on the test split, or trained to the end of its schedule by its log."""
    rel = run.relative_to(ROOT).as_posix()
    if f"{rel}/test.json" in tracked:
        return True
    if f"{rel}/log.csv" not in tracked:
        return False
    epochs = json.loads((run / "config.json").read_text())["train_config"]["epochs"]
    with open(run / "log.csv", newline="") as f:
        done = [int(r["epoch"]) for r in csv.DictReader(f) if r["kind"] == "epoch"]
    return bool(done) and max(done) == epochs


def test_tracked_weights_are_the_bundled_model_or_archived_final_checkpoints():
    tracked = _tracked()
    weights = sorted(p for p in tracked if p.lower().endswith(WEIGHTS))
    assert weights, "no weights tracked at all: the bundled model is missing"
    bad = [p for p in weights if not (BUNDLED.fullmatch(p) or ARCHIVED.fullmatch(p))]
    assert not bad, f"weights outside the bundled model and the archived runs: {bad}"
    for path in weights:
        folder = (ROOT / path).parent
        rel = folder.relative_to(ROOT).as_posix()
        assert f"{rel}/config.json" in tracked, path
        if BUNDLED.fullmatch(path):
            assert f"{rel}/CARD.md" in tracked, path
        else:
            assert _finished(folder, tracked), f"{path}: no test.json and no finished log.csv"
        if (ROOT / path).is_file():
            assert (ROOT / path).stat().st_size < MAX_BYTES, path


def test_no_resume_state_or_progress_snapshot_is_tracked():
    bad = sorted(
        p
        for p in _tracked()
        if p.startswith(("results/partial/", "results/.partial-"))
        or Path(p).name.startswith("trainer_state.")
    )
    assert not bad, bad


def test_gitignore_keeps_snapshots_and_stray_weights_out():
    kept_out = [
        "results/partial/navaff-12ep/model.safetensors",
        "results/partial/navaff-12ep/trainer_state.json",
        "results/.partial-abc123/model.safetensors",
        "results/runs/navaff-12ep/trainer_state.safetensors",
        "results/runs/navaff-12ep/trainer_state.json",
        "results/runs/navaff-12ep/views/model.safetensors",
        "runs/navaff/model.safetensors",
        "tests/data/tiny.safetensors",
        "model.pt",
        "weights.ckpt",
    ]
    allowed = [
        "results/runs/some-run/model.safetensors",
        "src/momakitchen/checkpoints/some-model/model.safetensors",
    ]
    try:
        out = subprocess.run(
            ["git", "check-ignore", "--no-index", "--stdin"],
            cwd=ROOT,
            input="\n".join(kept_out + allowed) + "\n",
            capture_output=True,
            text=True,
        )
    except OSError:
        pytest.skip("git is not installed")
    if out.returncode not in (0, 1):
        pytest.skip("not a git checkout")
    ignored = set(out.stdout.split())
    assert ignored == set(kept_out), (
        sorted(set(kept_out) - ignored),
        sorted(ignored - set(kept_out)),
    )
