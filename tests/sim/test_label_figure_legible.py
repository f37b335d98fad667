"""The label figure as the README and docs/LABELS.md show it (a page 8.6 in wide): every
text 8 pt or more there, the plans' axes in metres, every mark in the legend (the trial
stages, the target, the mask's colour, the furniture's colours), nothing on top of another."""

from __future__ import annotations

import numpy as np

from figure_helpers import assert_axes_labelled, assert_legible, legend_labels, plot_axes
from momakitchen.robots.spec import get_robot_spec
from momakitchen.scene.configuration import sample_scene
from momakitchen.scene.geometry import semicircle_grid
from momakitchen.sim.config import STAGE_NAMES, Stage
from momakitchen.sim.label_figure import save_label_figure
from momakitchen.sim.labels import Labels


def saved_figure(monkeypatch, save):
    """The figure ``save()`` writes, kept open for inspection."""
    from matplotlib.figure import Figure

    figures = []
    original = Figure.savefig
    monkeypatch.setattr(
        Figure, "savefig", lambda self, *a, **k: (figures.append(self), original(self, *a, **k))
    )
    save()
    (fig,) = figures
    return fig


def assert_apart(fig):
    """The names drawn on the plans lie inside their plan, apart from each other; no legend
    covers a plan."""
    plans = plot_axes(fig)
    for ax in plans:
        box = ax.get_window_extent()
        names = [t for t in ax.texts if t.get_visible() and t.get_text().strip()]
        extents = [t.get_window_extent() for t in names]
        for t, e in zip(names, extents, strict=True):
            assert box.x0 - 1 <= e.x0 and e.x1 <= box.x1 + 1, t.get_text()
            assert box.y0 - 1 <= e.y0 and e.y1 <= box.y1 + 1, t.get_text()
        for i, a in enumerate(extents):
            for j in range(i + 1, len(extents)):
                assert not a.overlaps(extents[j]), (names[i].get_text(), names[j].get_text())
    legends = [*fig.legends, *(ax.get_legend() for ax in fig.axes)]
    for legend in (lg for lg in legends if lg is not None):
        for ax in plans:
            assert not legend.get_window_extent().overlaps(ax.get_window_extent())


def test_the_label_figure_is_legible_at_the_page_width(tmp_path, monkeypatch):
    scene = sample_scene(12)
    cfg = scene.configurations[1]
    reach = get_robot_spec(cfg.robot).reach
    grid = semicircle_grid(cfg.target.anchor[:2], reach, 0.1)
    stages = np.arange(len(grid)) % len(Stage)  # every stage, a success among them
    labels = Labels(
        scene_id=12,
        config_index=1,
        robot=cfg.robot,
        target="cabinet/door",
        anchor=tuple(float(v) for v in cfg.target.anchor),
        grid_spacing=0.1,
        positions=np.asarray(grid, np.float64),
        yaws=np.zeros(len(grid)),
        stages=stages,
        moved=np.zeros(len(grid)),
        seconds={},
    )
    fig = saved_figure(
        monkeypatch, lambda: save_label_figure(scene.layout, cfg, labels, tmp_path / "l.png")
    )
    assert_legible(fig)
    assert_axes_labelled(fig)
    assert len(plot_axes(fig)) == 2
    text = "\n".join(legend_labels(fig))
    counts = labels.stage_counts()
    for name in STAGE_NAMES:
        assert f"{name.replace('_', ' ')} ({counts[name]})" in text
    flat = " ".join(text.split())  # a long entry breaks over lines
    assert "target" in flat and "base does not fit" in flat
    # the colours of the furniture about the target (the cabinets, the sink)
    assert "cabinet" in text and "sink" in text
    bars = [ax for ax in fig.axes if ax.get_label() == "<colorbar>"]
    assert bars and any("affordance" in ax.get_ylabel() + ax.get_xlabel() for ax in bars)
    assert_apart(fig)
