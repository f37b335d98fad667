"""loss_curve.png: its y axis is labelled and readable however narrow the loss range."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from momakitchen.train.trainer import plot_loss_curve


def _rows(high: float, low: float) -> list[dict[str, str]]:
    losses = np.geomspace(high, low, 40)
    rows = [{"kind": "train", "step": str(50 * i), "loss": str(v)} for i, v in enumerate(losses)]
    rows += [
        {"kind": "epoch", "step": str(500 * k), "loss": str(losses[10 * k - 1]), "val_loss": ""}
        for k in (1, 2, 3, 4)
    ]
    return rows


@pytest.mark.parametrize(("high", "low"), [(0.05, 0.02), (0.5, 0.002)])
def test_the_y_axis_label_and_ticks_are_inside_the_picture(tmp_path, monkeypatch, high, low):
    from matplotlib.figure import Figure

    figures = []
    monkeypatch.setattr(
        Figure,
        "savefig",
        lambda self, *a, _orig=Figure.savefig, **k: (figures.append(self), _orig(self, *a, **k))[1],
    )
    path = tmp_path / "loss_curve.png"
    plot_loss_curve(_rows(high, low), path, "navaff")
    (fig,) = figures
    ax = fig.axes[0]
    renderer = fig.canvas.get_renderer()
    label = ax.yaxis.label.get_window_extent(renderer)
    assert ax.get_ylabel() == "loss" and label.x0 >= 0
    shown = [
        t
        for t in ax.yaxis.get_ticklabels(minor=False) + ax.yaxis.get_ticklabels(minor=True)
        if t.get_text() and low <= t.get_position()[1] <= high
    ]
    assert len(shown) >= 2, "fewer than two labelled y ticks"
    assert all(t.get_window_extent(renderer).x0 >= 0 for t in shown)
    assert all("10^" not in t.get_text() and "times" not in t.get_text() for t in shown)
    assert Image.open(path).size == (600, 400)
