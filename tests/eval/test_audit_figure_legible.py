"""The label audit's picture as README.md, docs/LABELS.md and docs/RESULTS.md show it (a
page 8.6 in wide): every text 8 pt or more there, the shares in %, every mark in the
legend (each measure with its goal, the dashed goal lines), no text on another, even with
many targets of long names."""

from __future__ import annotations

from itertools import combinations

import pytest

from figure_helpers import assert_legible, captured_figures, legend_labels, plot_axes, texts
from momakitchen.eval import audit as au
from momakitchen.perception.figures import DOC_WIDTH

TARGETS = (
    "bottle", "cabinet/door", "cabinet/drawer", "dishwasher/door", "fridge/door",
    "fridge/drawer", "fruit", "medicine_bottle", "microwave/door", "oven/door",
    "oven/drawer", "pot", "sink/door", "sink/lever", "vegetable",
)  # fmt: skip
ROBOTS = ("elephant", "flexiv", "panda", "realman", "ur5e", "xarm6")


def _record(robot, target, feasible):
    stages = dict.fromkeys(("success", "base_collision", "ik_failed", "execution_failed"), 0)
    stages["success" if feasible else "ik_failed"] = 3
    outcomes = [1, 0] if feasible else []
    return {
        "robot": robot,
        "target": target,
        "feasible": feasible,
        "grid": {"stages": stages},
        "stability": {k: {"outcomes": outcomes, "stages": []} for k in ("3cm", "5cm", "yaw10")},
        "views_covering": [True, feasible],
        "methods": {name: {"outcomes": [int(feasible), 0]} for name in au.BASELINES},
    }


@pytest.fixture
def figure(monkeypatch):
    records = [
        _record(robot, target, feasible=(i + j) % 4 != 0)
        for i, robot in enumerate(ROBOTS)
        for j, target in enumerate(TARGETS)
    ]
    config = au.AuditConfig()
    summary = au.summarize(records, config)
    with captured_figures(monkeypatch) as kept:
        assert au.audit_figure(summary, config)[:8] == b"\x89PNG\r\n\x1a\n"
    (fig,) = kept
    return fig


def test_the_audit_figure_is_legible_at_the_page_width(figure):
    assert figure.get_size_inches()[0] == pytest.approx(DOC_WIDTH)
    assert_legible(figure)
    panels = plot_axes(figure)
    assert len(panels) == 2
    for ax, noun in zip(panels, ("robot", "target"), strict=True):
        assert "(%)" in ax.get_ylabel()
        assert noun in ax.get_xlabel()
        names = " ".join(t.get_text() for t in ax.get_xticklabels())
        for name in ROBOTS if noun == "robot" else TARGETS:
            assert name in names


def test_every_mark_is_in_the_legend(figure):
    labels = legend_labels(figure)
    for measure, goal in (
        ("infeasible", "≤ 10 %"),
        ("oracle Top-1", "≥ 90 %"),
        ("±3 cm", "≥ 90 %"),
        ("view coverage", "≥ 95 %"),
    ):
        assert any(measure in label and goal in label for label in labels), (measure, labels)
    assert any("goal" in label and "dashed" in label for label in labels)
    for ax in plot_axes(figure):  # four measures, each with its goal line
        assert len(ax.containers) == 4 and len(ax.collections) == 4


def test_no_text_lies_on_another(figure):
    shown = texts(figure)
    extents = [t.get_window_extent() for t in shown]
    for (a, ea), (b, eb) in combinations(zip(shown, extents, strict=True), 2):
        assert not ea.overlaps(eb), (a.get_text(), b.get_text())
    legends = [*figure.legends, *(ax.get_legend() for ax in figure.axes)]
    for legend in (lg for lg in legends if lg is not None):
        for ax in plot_axes(figure):
            assert not legend.get_window_extent().overlaps(ax.get_window_extent())
    page = figure.bbox
    for t, e in zip(shown, extents, strict=True):
        assert page.x0 - 1 <= e.x0 and e.x1 <= page.x1 + 1, t.get_text()
        assert page.y0 - 1 <= e.y0 and e.y1 <= page.y1 + 1, t.get_text()
