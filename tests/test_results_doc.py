"""docs/RESULTS.md opens with one table, the paper's figures beside ours for every method,
and ours are those of the archived runs (results/runs/), not typed by hand; then the
robustness and audit sections; every table comes with the command that remakes it; the
history lives in docs/results/HISTORY.md."""

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
    "NavAff through simulated real sensors (the bundled model)": "navaff-12ep-noise-mild",
    "PointNet++": "pointnet2-12ep",
    "VoteNet": "votenet-12ep",
    "H3DNet": "h3dnet-12ep",
    "random": "random",
    "nearest": "nearest",
    "oracle": "oracle",
}
PAPER = {  # the paper's figures: RMSE, logMSE, PCC, SIM, Top-1, Top-5 (– where it gives none)
    "**NavAff**": ("0.147", "0.0115", "0.680", "0.696", "72 %", "66 %"),
    "PointNet++": ("–", "–", "–", "–", "60 %", "–"),
    "VoteNet": ("–", "–", "–", "–", "56 %", "–"),
    "H3DNet": ("–", "–", "–", "–", "54 %", "–"),
    "random": ("–", "–", "–", "–", "8 %", "–"),
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


def _ours(run: str) -> tuple[str, ...]:
    if run in ("random", "nearest", "oracle"):
        rates = json.loads((RUNS / "msr-baselines.json").read_text())["methods"][run]
        maps = ("–",) * 4
    else:
        metrics = json.loads((RUNS / run / "test.json").read_text())["metrics"]
        (rates,) = json.loads((RUNS / run / "msr.json").read_text())["methods"].values()
        maps = tuple(
            f"{metrics[k]:.{d}f}" for k, d in [("rmse", 3), ("logmse", 4), ("pcc", 3), ("sim", 3)]
        )
    return (*maps, f"{100 * rates['top1']:.1f} %", f"{100 * rates['topk']:.1f} %")


def test_results_open_with_the_paper_beside_ours():
    assert _sections()[:6] == [
        "Ours beside the paper's",
        "Learning against geometry",
        "The last mile as driven",
        "Robots the model never saw",
        "Robustness to real sensors",
        "The label audit: do the labels predict success?",
    ]
    table = _first_table()
    found = {}
    for cells in table:
        key = max((k for k in ROWS if cells[0].startswith(k)), key=len, default=None)
        assert key is not None, cells
        found[key] = cells
    assert set(found) == set(ROWS)
    for key, cells in found.items():
        ours = _ours(ROWS[key])
        paper = PAPER.get(key, ("–",) * 6)
        numbers = [c.replace("**", "") for c in cells[1:]]
        assert numbers[1::2] == list(ours), (key, numbers)
        assert numbers[0::2] == list(paper), (key, numbers)


def test_the_history_is_elsewhere():
    history = (ROOT / "docs" / "results" / "HISTORY.md").read_text(encoding="utf-8")
    assert "Earlier results: 100 scenes" in history and "100 scenes" not in RESULTS[:3000]
    assert "Made again on another machine" in history
    assert "Made again on another machine" not in RESULTS


def test_every_table_has_its_command():
    """Each section of RESULTS.md that holds a table holds the command that remakes it (a
    bash block, or the command in the table's own rows, as the audit's)."""
    for section in re.split(r"^#{2,3} ", RESULTS, flags=re.M)[1:]:
        tables = re.findall(r"(?:^\|.*\n)+", re.sub(r"```.*?```", "", section, flags=re.S), re.M)
        if tables:
            assert "```bash" in section or all("`momakitchen " in x for x in tables), section[:80]


def test_the_bundled_models_figures_are_one_everywhere():
    """The bundled model's Top-1 / Top-5 of its run's msr.json, quoted alike in the README,
    RESULTS.md and the model's card."""
    (rates,) = json.loads((RUNS / "navaff-12ep-noise-mild" / "msr.json").read_text())[
        "methods"
    ].values()
    top1, top5 = f"{100 * rates['top1']:.1f} %", f"{100 * rates['topk']:.1f} %"
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    card = (ROOT / "src" / "momakitchen" / "checkpoints" / "navaff" / "CARD.md").read_text()
    row = next(line for line in readme.splitlines() if line.startswith("| NavAff Top-5"))
    assert row.rstrip(" |").endswith(top5), row
    assert f"Top-1 {top1}, Top-5 {top5}" in card
    for line in RESULTS.splitlines():
        if line.startswith("| NavAff through simulated real sensors") and "%" in line:
            assert top1 in line and top5 in line, line
