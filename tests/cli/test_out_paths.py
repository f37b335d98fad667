"""An --out that cannot be a directory fails at once, one line, exit 2 (export-reference
and train used to end in a traceback after their work)."""

from __future__ import annotations

import pytest

from momakitchen.cli.main import main


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    root = tmp_path_factory.mktemp("ds") / "syn"
    assert main(["generate", "--synthetic", "--out", str(root), "--scenes", "2", "--quiet"]) == 0
    return root


@pytest.mark.parametrize("command", ["export-reference", "train"])
@pytest.mark.parametrize("where", ["file", "under_file", "proc"])
def test_impossible_out_is_refused_before_work(dataset, tmp_path, capsys, command, where):
    afile = tmp_path / "afile"
    afile.write_text("keep me")
    out = {"file": afile, "under_file": afile / "sub", "proc": "/proc/momakitchen-nope/x"}[where]
    argv = (
        ["export-reference", str(dataset), "--out", str(out)]
        if command == "export-reference"
        else ["train", "--data", str(dataset), "--model", "navaff", "--out", str(out)]
    )
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"momakitchen {command}: error: ") and "\n" not in err
    assert "output directory" in err or "exists and is not an empty directory" in err
    assert afile.read_text() == "keep me"
