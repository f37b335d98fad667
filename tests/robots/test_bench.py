"""The benchmark module runs, reports what docs/bench/robots.md shows, and its figures are
the known ones on an easy case (xarm6: IK round trips and a top-down labelling sweep)."""

from __future__ import annotations

from momakitchen.robots.bench import main


def test_bench_reports_known_figures_for_xarm6(capsys):
    main(["--poses", "8", "--runs", "1", "--robots", "xarm6"])
    out = capsys.readouterr().out
    rows = [line for line in out.splitlines() if line.startswith("| xarm6 |")]
    assert len(rows) == 3  # workspace, IK round trip, labelling-like sweep
    ratio = float(rows[0].split("|")[4])
    assert 0.95 <= ratio <= 1.25
    # FK -> IK -> FK on 8 random reachable poses: all succeed today (the success check is
    # an independent FK comparison within 5 mm and 2 degrees); allow one miss.
    success = float(rows[1].split("|")[2])
    assert success >= 7 / 8
    # The sweep: 41 points of a 10 cm grid within the 0.70 m reach, in front of the
    # counter edge (x = -0.3 is in: np.arange gives -0.30000000000000004). A top-down grasp
    # 0.1 m below the mount is reachable from (almost) every one: all 41 today.
    cells = rows[2].split("|")
    assert int(cells[2]) == 41
    assert int(cells[3]) >= 39
