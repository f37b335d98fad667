"""docs/RESULTS.md opens with one table, the paper's figures beside ours for every method,
and ours are those of the archived runs (results/runs/), not typed by hand; then the
robustness and audit sections; the history lives in docs/results/HISTORY.md."""

from __future__ import annotations

import json
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = (ROOT / "docs" / "RESULTS.md").read_text(encoding="utf-8")
RUNS = ROOT / "results" / "runs"
# method row -> archived run (None: a baseline of msr-baselines.json)
ROWS = {
    "**NavAff**": "navaff-12ep",
    "PointNet++": "pointnet2-12ep",
    "VoteNet": "votenet-12ep",
    "H3DNet": "h3dnet-12ep",
    "random": "random",
    "nearest": "nearest",
    "oracle": "oracle",
}
PAPER = {  # the paper's figures: PCC, SIM, Top-1, Top-5 (– where it gives none)
    "**NavAff**": ("0.680", "0.696", "72 %", "66 %"),
    "PointNet++": ("–", "–", "60 %", "–"),
    "VoteNet": ("–", "–", "56 %", "–"),
    "H3DNet": ("–", "–", "54 %", "–"),
    "random": ("–", "–", "8 %", "–"),
}


def _sections() -> list[str]:
    return re.findall(r"^## (.+)$", RESULTS, re.M)


def _first_table() -> list[list[str]]:
    body = RESULTS[RESULTS.index("## ") :]
    rows = [line for line in body.splitlines() if line.startswith("|")]
    table = []
    for line in rows:
        cells = [c.strip() for c in line.strip("|").split("|")]
        if table and len(cells) != len(table[0]):
            break
        table.append(cells)
    return table[2:]


def _ours(run: str) -> tuple[str, str, str, str]:
    if run in ("random", "nearest", "oracle"):
        rates = json.loads((RUNS / "msr-baselines.json").read_text())["methods"][run]
        pcc = sim = "–"
    else:
        metrics = json.loads((RUNS / run / "test.json").read_text())["metrics"]
        (rates,) = json.loads((RUNS / run / "msr.json").read_text())["methods"].values()
        pcc, sim = f"{metrics['pcc']:.3f}", f"{metrics['sim']:.3f}"
    return pcc, sim, f"{100 * rates['top1']:.1f} %", f"{100 * rates['topk']:.1f} %"


def test_results_open_with_the_paper_beside_ours():
    assert _sections()[:3] == [
        "Ours beside the paper's",
        "Robustness to real sensors",
        "The label audit: do the labels predict success?",
    ]
    table = _first_table()
    found = {}
    for cells in table:
        key = next((k for k in ROWS if cells[0].startswith(k)), None)
        assert key is not None, cells
        found[key] = cells
    assert set(found) == set(ROWS)
    for key, cells in found.items():
        ours = _ours(ROWS[key])
        paper = PAPER.get(key, ("–", "–", "–", "–"))
        numbers = [c.replace("**", "") for c in cells[1:]]
        assert numbers[1::2] == list(ours), (key, numbers)
        assert numbers[0::2] == list(paper), (key, numbers)


def test_results_are_short_and_the_history_is_elsewhere():
    assert len(RESULTS.splitlines()) < 800
    history = (ROOT / "docs" / "results" / "HISTORY.md").read_text(encoding="utf-8")
    assert "Earlier results: 100 scenes" in history and "100 scenes" not in RESULTS[:3000]
    assert "Made again on another machine" in history
    assert "Made again on another machine" not in RESULTS
