"""The benchmark module runs and reports what docs/bench/robots.md shows."""

from __future__ import annotations

from momakitchen.robots.bench import main


def test_bench_smoke(capsys):
    main(["--poses", "4", "--runs", "1", "--robots", "xarm6"])
    out = capsys.readouterr().out
    rows = [line for line in out.splitlines() if line.startswith("| xarm6 |")]
    assert len(rows) == 3  # workspace, IK round trip, labelling-like sweep
    ratio = float(rows[0].split("|")[4])
    assert 0.95 <= ratio <= 1.25
    success = float(rows[1].split("|")[2])
    assert 0.0 <= success <= 1.0
