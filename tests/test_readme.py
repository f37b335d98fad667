"""The README's set-up installs what it says (the CPU build of PyTorch, from PyTorch's
index) and its tour is one path: the dataset it generates has both splits, and the
commands after it read that dataset and the runs the tour trains."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

from momakitchen.data.manifest import scene_split

README = (Path(__file__).resolve().parents[1] / "README.md").read_text(encoding="utf-8")
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
            line = re.sub(r"\[[^\]]*\]", "", line.split("#")[0]).strip()
            if line.startswith("momakitchen "):
                out.append(shlex.split(line))
    return out


def _option(argv: list[str], name: str, default: str | None = None) -> str | None:
    return argv[argv.index(name) + 1] if name in argv else default


def test_setup_installs_the_cpu_build_and_says_what_the_pin_alone_does():
    setup = _section("## Set-up")
    block = re.search(r"```bash\n(.*?)```", setup, re.S).group(1)
    first = block.splitlines()[0]
    assert first.startswith(f"pip install torch==2.13.0 {CPU_INDEX} && ")
    assert 'pip install -e ".[dev]"' in first
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


def test_the_index_url_is_explained_to_users_in_two_sentences():
    paragraph = next(p for p in _section("## Set-up").split("\n\n") if "Why the index URL" in p)
    assert len(re.findall(r"[.!?](?:\s|$)", paragraph.strip())) == 2, paragraph


def test_the_msr_section_keeps_its_table_and_one_paragraph():
    """The statistics live in docs/RESULTS.md; after its table the README says one thing."""
    section = _section("## A tour of the commands")
    msr = section[section.index("### `momakitchen msr`") : section.index("### `momakitchen audit`")]
    after = msr[msr.rindex("\n|") :].split("\n", 2)[2].strip()
    assert len(after.split("\n\n")) == 1 and "docs/RESULTS.md" in after, after
