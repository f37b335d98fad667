"""The README's set-up installs what it says (the CPU build of PyTorch, from PyTorch's
index); its tour is one path (the dataset it generates has both splits, and the commands
after it read that dataset and the runs the tour trains) with a command for every
subcommand; its results table is the archived runs' figures; it puts the results and the
real robot before the tour, whose every entry is one command and one paragraph."""

from __future__ import annotations

import json
import re
import shlex
from pathlib import Path

from momakitchen.cli.main import COMMANDS
from momakitchen.data.manifest import scene_split

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text(encoding="utf-8")
RUNS = ROOT / "results" / "runs"
CPU_INDEX = "--index-url https://download.pytorch.org/whl/cpu"


def _section(title: str) -> str:
    start = README.index(title)
    return README[start : README.index("\n## ", start + 1)]


def _commands(text: str) -> list[list[str]]:
    """The `momakitchen ...` commands of the bash blocks of ``text`` (continuations
    joined, comments and [optional parts] dropped)."""
    out = []
    for block in re.findall(r"```bash\n(.*?)```", text, re.S):
        for line in block.replace("\\\n", " ").splitlines():
            line = re.sub(r"\[[^\]]*\]", "", line.split("#")[0])
            for part in line.split("&&"):
                if part.strip().startswith("momakitchen "):
                    out.append(shlex.split(part))
    return out


def _option(argv: list[str], name: str, default: str | None = None) -> str | None:
    return argv[argv.index(name) + 1] if name in argv else default


def test_setup_installs_the_cpu_build_and_says_what_the_pin_alone_does():
    setup = _section("## Set-up")
    block = re.search(r"```bash\n(.*?)```", setup, re.S).group(1)
    first = block.splitlines()[0]
    assert first.startswith(f"pip install torch==2.13.0 {CPU_INDEX} && ")
    assert 'pip install -e ".[dev,robot]"' in first
    # The pin alone: the CUDA build from PyPI, the CPU build only from a local wheel.
    assert "CUDA" in setup and "nvidia-" in setup and "triton" in setup
    assert "installs the package (with the CPU build" not in README


def test_the_tour_is_one_path_on_a_dataset_with_both_splits():
    tour = _commands(_section("## A tour of the commands"))
    generate = next(a for a in tour if a[1] == "generate")
    first = int(_option(generate, "--first-scene-id", "0"))
    ids = range(first, first + int(_option(generate, "--scenes")))
    assert {scene_split(s) for s in ids} == {"train", "test"}
    data = _option(generate, "--out")
    trained = {_option(a, "--out") for a in tour if a[1] == "train"}
    for argv in tour:
        if argv[1] in ("check", "stats", "export-reference"):
            assert argv[2] == data, argv
        if "--data" in argv:
            assert _option(argv, "--data") == data, argv
        if argv[1] in ("evaluate", "msr"):
            runs = [argv[i + 1] for i, a in enumerate(argv) if a == "--checkpoint"]
            assert runs and set(runs) <= trained, argv


def test_the_tour_writes_nothing_into_the_working_directory_itself():
    """Every --out of the tour is a path under a folder (out/, data/, runs/, ...), not a
    file dropped beside the repository's own files."""
    for argv in _commands(_section("## A tour of the commands")):
        out = _option(argv, "--out")
        assert out is None or "/" in out.rstrip("/"), argv


def test_the_index_url_says_what_pypi_gives_and_when_to_skip_it():
    paragraph = next(p for p in _section("## Set-up").split("\n\n") if "Why the index URL" in p)
    assert "PyPI" in paragraph and "CUDA" in paragraph, paragraph  # what the pin alone gets
    assert "skip the first `pip install`" in paragraph, paragraph


def test_every_subcommand_has_a_command_in_the_readme():
    used = {argv[1] for argv in _commands(README)}
    assert set(COMMANDS) <= used, sorted(set(COMMANDS) - used)


def _slug(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces to hyphens."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def test_the_contents_links_reach_headings():
    anchors = {_slug(h) for h in re.findall(r"^#+ (.+)$", README, re.M)}
    contents = _section("## Contents")
    links = re.findall(r"\]\(#([^)]+)\)", README)
    assert len(re.findall(r"\]\(#", contents)) >= 10, contents
    assert not [a for a in links if a not in anchors], sorted(anchors)
    tour = _section("## A tour of the commands")
    entries = {_slug(h) for h in re.findall(r"^### (.+)$", tour, re.M)}
    assert entries <= set(re.findall(r"\]\(#([^)]+)\)", contents)), entries


def test_results_and_the_real_robot_come_before_the_tour():
    """Narrow lines, the results and the real robot before the tour, and each tour entry
    one command block and one paragraph (the rest lives in docs/)."""
    lines = README.splitlines()
    setup = re.search(r"```bash\n(.*?)\n", _section("## Set-up"), re.S).group(1)
    wide = [(i, len(line)) for i, line in enumerate(lines, 1) if len(line) > 100 and line != setup]
    assert not wide, wide
    order = ["## Set-up", "## Contents", "## Our results beside the paper's", "## On a real robot"]
    order.append("## A tour of the commands")
    starts = [README.index(title) for title in order]
    assert starts == sorted(starts)
    tour = _section("## A tour of the commands")
    for entry in re.split(r"\n(?=### )", tour)[1:]:
        assert entry.count("```bash") == 1, entry
        prose = re.sub(r"```.*?```", "", entry, flags=re.S)
        prose = [p for p in prose.split("\n\n")[1:] if p.strip() and not p.startswith("![")]
        assert len(prose) == 1, entry


PAPER = {  # the paper's figures (docs/DESIGN.md)
    "NavAff RMSE ↓": "0.147",
    "NavAff logMSE ↓": "0.0115",
    "NavAff PCC ↑": "0.680",
    "NavAff SIM ↑": "0.696",
    "NavAff Top-1 MSR": "72 %",
    "NavAff Top-5 MSR": "66 %",
    "PointNet++ Top-1 MSR": "60 %",
    "VoteNet Top-1 MSR": "56 %",
    "H3DNet Top-1 MSR": "54 %",
    "random": "8 %",
    "oracle": "–",
}


def _figures(run: str) -> dict[str, str]:
    """A run's figures as the README rounds them, from its archived reports."""
    metrics = json.loads((RUNS / run / "test.json").read_text())["metrics"]
    (rates,) = json.loads((RUNS / run / "msr.json").read_text())["methods"].values()
    return {
        "RMSE": f"{metrics['rmse']:.3f}",
        "logMSE": f"{metrics['logmse']:.4f}",
        "PCC": f"{metrics['pcc']:.3f}",
        "SIM": f"{metrics['sim']:.3f}",
        "Top-1": f"{100 * rates['top1']:.1f} %",
        "Top-5": f"{100 * rates['topk']:.1f} %",
    }


def test_the_results_table_is_the_archived_runs():
    """Ours: `navaff-12ep`, the bundled model (`navaff-12ep-noise-mild`) and the 12-epoch
    baselines, each from its test.json / msr.json; the paper's as it reports them."""
    section = _section("## Our results beside the paper's")
    rows = [[c.strip() for c in line.strip("|").split("|")] for line in section.splitlines()]
    rows = [r for r in rows if len(r) == 4 and not r[0].startswith(("---", "figure"))]
    baselines = json.loads((RUNS / "msr-baselines.json").read_text())["methods"]
    runs = {
        f"{m} Top-1 MSR": f"{r}-12ep"
        for m, r in [("PointNet++", "pointnet2"), ("VoteNet", "votenet"), ("H3DNet", "h3dnet")]
    }
    navaff, bundled = _figures("navaff-12ep"), _figures("navaff-12ep-noise-mild")
    seen = set()
    for name, paper, ours, ours_bundled in rows:
        key = next(k for k in PAPER if name.startswith(k))
        seen.add(key)
        assert paper == PAPER[key], name
        metric = next(m for m in navaff if f" {m} " in f" {name} ")
        if name.startswith("NavAff"):
            assert (ours, ours_bundled) == (navaff[metric], bundled[metric]), name
        elif key in runs:
            assert (ours, ours_bundled) == (_figures(runs[key])[metric], ""), name
        else:
            assert (ours, ours_bundled) == (f"{100 * baselines[key]['top1']:.1f} %", ""), name
    assert seen == set(PAPER)
