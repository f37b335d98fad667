"""The scene overview as the README's first picture shows it (a page 8.6 in wide): every
text 8 pt or more there, the plan's axes in metres, every mark in the legend (each
category's colour, the target, the handles, the sampling semicircle and its grid), nothing
on top of another."""

from __future__ import annotations

import numpy as np
import pytest

from figure_helpers import assert_axes_labelled, assert_legible, legend_labels, plot_axes
from momakitchen.robots.spec import get_robot_spec
from momakitchen.scene.configuration import sample_scene
from momakitchen.scene.overview import save_overview


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


@pytest.mark.parametrize("rendered", [True, False], ids=["view", "no-render"])
def test_the_overview_is_legible_at_the_readme_width(tmp_path, monkeypatch, rendered):
    scene = sample_scene(7)
    cfg = scene.configurations[0]
    view = np.full((600, 800, 3), 180, np.uint8) if rendered else None
    fig = saved_figure(monkeypatch, lambda: save_overview(scene, 0, view, tmp_path / "o.png"))
    assert_legible(fig)
    assert_axes_labelled(fig)
    (plan,) = plot_axes(fig)
    labels = legend_labels(fig)
    present = {u.category for u in scene.layout.furniture}
    present |= {o.category for o in (*cfg.objects, *cfg.obstacles)}
    assert {c.replace("_", " ") for c in present} <= set(labels)
    text = "\n".join(labels)
    reach = get_robot_spec(cfg.robot).reach
    assert f"target: {cfg.target.category}" in text
    assert "handle" in text and "floor" in text
    assert "semicircle" in text and f"{reach} m" in text
    assert "base position" in text  # the grid of the trials' base positions
    # the names on the plan lie inside it and apart; the legend covers no plot
    box = plan.get_window_extent()
    names = [t for t in plan.texts if t.get_visible() and t.get_text().strip()]
    extents = [t.get_window_extent() for t in names]
    for t, e in zip(names, extents, strict=True):
        assert box.x0 - 1 <= e.x0 and e.x1 <= box.x1 + 1, t.get_text()
        assert box.y0 - 1 <= e.y0 and e.y1 <= box.y1 + 1, t.get_text()
    for i, a in enumerate(extents):
        for j in range(i + 1, len(extents)):
            assert not a.overlaps(extents[j]), (names[i].get_text(), names[j].get_text())
    legends = [*fig.legends, *(ax.get_legend() for ax in fig.axes)]
    for legend in (lg for lg in legends if lg is not None):
        for ax in fig.axes:
            if ax.get_legend() is not legend:
                assert not legend.get_window_extent().overlaps(ax.get_window_extent())


def test_the_page_numbers_are_perceptions():
    """The scene layer repeats perception's page width and smallest text size."""
    from momakitchen.perception import figures
    from momakitchen.scene import overview

    assert (overview.DOC_WIDTH, overview.MIN_POINTS) == (figures.DOC_WIDTH, figures.MIN_POINTS)
    assert overview.text_sizes(9.0).items() >= figures.text_sizes(9.0).items()
