"""Checks that a figure the documents show is readable there: every text at least
MIN_POINTS at the width a page shows it (DOC_WIDTH inches), every plot's axes labelled with
units, and the marks explained by a legend."""

from __future__ import annotations

import contextlib

from momakitchen.perception.figures import DOC_WIDTH, MIN_POINTS


def texts(fig):
    """Every visible, non-empty text of a drawn figure (tick labels, titles, legends,
    colour bars and annotations)."""
    from matplotlib.text import Text

    fig.canvas.draw()
    return [
        t
        for t in fig.findobj(Text)
        if t.get_visible() and t.get_text().strip() and t.get_figure() is not None
    ]


def shown_points(fig, text) -> float:
    """A text's size as a page DOC_WIDTH inches wide shows it."""
    width = fig.get_size_inches()[0]
    return text.get_fontsize() * min(1.0, DOC_WIDTH / width)


def assert_legible(fig):
    small = [
        (t.get_text()[:40], round(shown_points(fig, t), 1))
        for t in texts(fig)
        if shown_points(fig, t) < MIN_POINTS - 1e-6
    ]
    assert not small, f"text under {MIN_POINTS} pt at the page's width: {small[:8]}"


def plot_axes(fig):
    """The axes that show data on x/y axes (not images turned off, not colour bars, not
    text panels)."""
    out = []
    for ax in fig.axes:
        if not ax.axison or ax.get_label() == "<colorbar>":
            continue
        if not (ax.lines or ax.collections or ax.images or ax.patches):
            continue
        out.append(ax)
    return out


def assert_axes_labelled(fig, unit="(m)"):
    for ax in plot_axes(fig):
        for label in (ax.get_xlabel(), ax.get_ylabel()):
            assert unit in label, (ax.get_title(), ax.get_xlabel(), ax.get_ylabel())


def legend_labels(fig):
    labels = []
    legends = [*fig.legends, *(ax.get_legend() for ax in fig.axes)]
    for legend in legends:
        if legend is not None:
            labels += [t.get_text() for t in legend.get_texts()]
    return labels


@contextlib.contextmanager
def captured_figures(monkeypatch):
    """The figures handed to ``png_bytes`` (every figure function's last step) while the
    block runs, kept open for inspection."""
    from momakitchen.perception import figures

    kept = []
    real = figures.png_bytes

    def keep(fig, *args, **kwargs):
        kept.append(fig)
        data = real(fig, *args, **kwargs)
        return data

    monkeypatch.setattr(figures, "png_bytes", keep)
    yield kept
