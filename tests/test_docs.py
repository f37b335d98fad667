"""The repository documents itself: what its files cite lies inside it.

Fails on a citation of a path outside the repository, a ``DESIGN.md §N`` section that
``docs/DESIGN.md`` does not have, a ``docs/X.md`` that does not exist, or a relative
Markdown link to a missing file.
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DESIGN = ROOT / "docs" / "DESIGN.md"
TEXT_SUFFIXES = {
    ".py",
    ".md",
    ".toml",
    ".yaml",
    ".yml",
    ".txt",
    ".cfg",
    ".ini",
    ".json",
    ".rst",
    ".sh",
}
SKIP_DIRS = {
    ".git",
    "__pycache__",
    ".pytest_cache",
    ".ruff_cache",
    ".mypy_cache",
    ".venv",
    "venv",
    "build",
    "dist",
    "node_modules",
}
SELF = Path(__file__).resolve()

# Built from pieces so that this file does not cite what it looks for.
OUTSIDE = re.compile(r"(?<![\w.-])(?:" + "sha" + r"red/|\.\./)")
SECTION_CITE = re.compile(r"DESIGN\.md`?\s*§\s*(\d+(?:\.\d+)*)")
DOCS_CITE = re.compile(r"(?<![\w/.-])docs/[\w./-]*?\.md\b")
MD_LINK = re.compile(r"\]\(([^)\s#]+)(?:#[^)]*)?\)")
HEADING = re.compile(r"^#+\s+(\d+(?:\.\d+)*)\.?\s", re.MULTILINE)


def repo_files() -> list[Path]:
    """Text files of the repository: tracked and untracked-but-not-ignored (git), else all."""
    try:
        out = subprocess.run(
            ["git", "ls-files", "--cached", "--others", "--exclude-standard", "-z"],
            cwd=ROOT,
            capture_output=True,
            check=True,
            text=True,
        )
        paths = [ROOT / p for p in out.stdout.split("\0") if p]
    except (OSError, subprocess.CalledProcessError):
        paths = [
            p for p in ROOT.rglob("*") if not SKIP_DIRS.intersection(p.relative_to(ROOT).parts)
        ]
    return sorted(
        p
        for p in paths
        if p.is_file()
        and p.suffix in TEXT_SUFFIXES
        and p.resolve() != SELF
        and not any(part.endswith(".egg-info") for part in p.parts)
    )


FILES = repo_files()


def read(path: Path) -> str:
    try:
        return path.read_text(encoding="utf-8")
    except (UnicodeDecodeError, OSError):
        return ""


def design_sections() -> set[str]:
    return set(HEADING.findall(DESIGN.read_text(encoding="utf-8")))


def where(path: Path, text: str, pos: int) -> str:
    return f"{path.relative_to(ROOT)}:{text.count(chr(10), 0, pos) + 1}"


def test_design_document_exists_with_its_sections():
    sections = design_sections()
    assert {"1", "2", "3", "3.1", "3.4", "3.6", "3.7", "4", "5", "6"} <= sections, sections


def _link_inside(path: Path, text: str, pos: int) -> bool:
    """Whether the ``../`` at ``pos`` starts a Markdown link target (``](../X)``) of a
    Markdown file that stays inside the repository (a document in a sub-folder of docs/
    links to its parent's files so)."""
    if path.suffix != ".md" or text[max(0, pos - 2) : pos] != "](":
        return False
    end = text.find(")", pos)
    target = text[pos:end].split("#")[0]
    return end > pos and (path.parent / target).resolve().is_relative_to(ROOT)


def test_nothing_cites_a_path_outside_the_repository():
    bad = [
        f"{where(p, t, m.start())}: {m.group(0)!r}"
        for p in FILES
        for t in [read(p)]
        for m in OUTSIDE.finditer(t)
        if not _link_inside(p, t, m.start())
    ]
    assert not bad, bad


def test_cited_design_sections_exist():
    sections = design_sections()
    bad = [
        f"{where(p, t, m.start())}: §{m.group(1)}"
        for p in FILES
        for t in [read(p)]
        for m in SECTION_CITE.finditer(t)
        if m.group(1) not in sections
    ]
    assert not bad, f"sections of docs/DESIGN.md: {sorted(sections)}; cited: {bad}"


def test_cited_docs_files_exist():
    bad = [
        f"{where(p, t, m.start())}: {m.group(0)}"
        for p in FILES
        for t in [read(p)]
        for m in DOCS_CITE.finditer(t)
        if not (ROOT / m.group(0)).is_file()
    ]
    assert not bad, bad


@pytest.mark.parametrize(
    "path", [p for p in FILES if p.suffix == ".md"], ids=lambda p: str(p.relative_to(ROOT))
)
def test_markdown_links_resolve_inside_the_repository(path: Path):
    text = read(path)
    bad = []
    for m in MD_LINK.finditer(text):
        target = m.group(1)
        if re.match(r"[a-z][a-z0-9+.-]*:", target):  # http:, https:, mailto:
            continue
        resolved = (path.parent / target).resolve()
        if not resolved.is_relative_to(ROOT) or not resolved.exists():
            bad.append(f"{where(path, text, m.start())}: {target}")
    assert not bad, bad


def _anchors(path: Path) -> set[str]:
    """GitHub's anchors of a Markdown file's headings: lower case, punctuation dropped,
    spaces to hyphens (outside code blocks)."""
    text = re.sub(r"```.*?```", "", read(path), flags=re.S)
    return {
        re.sub(r"[^\w\- ]", "", h.strip().lower()).replace(" ", "-")
        for h in re.findall(r"^#+ (.+)$", text, re.M)
    }


# The documents whose sections other files link to by anchor.
ANCHORED = [
    ROOT / "README.md",
    ROOT / "docs" / "RESULTS.md",
    ROOT / "docs" / "results" / "HISTORY.md",
]


def test_links_into_the_results_and_readme_reach_their_sections():
    """A link `FILE#anchor` (or `#anchor` within the file) to the README, RESULTS.md or its
    history names a heading of that file, so moving a section does not strand its links."""
    anchors = {p.resolve(): _anchors(p) for p in ANCHORED}
    bad = []
    for path in (p for p in FILES if p.suffix == ".md"):
        text = read(path)
        for m in re.finditer(r"\]\(([^)\s#]*)#([^)\s]+)\)", text):
            target = (path.parent / m.group(1)).resolve() if m.group(1) else path.resolve()
            if target in anchors and m.group(2) not in anchors[target]:
                bad.append(f"{where(path, text, m.start())}: {m.group(1)}#{m.group(2)}")
    assert not bad, bad
