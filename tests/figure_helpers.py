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
    """Every plot's axes say what they measure, in ``unit``: its own labels, or the
    figure's (``supxlabel``, ``supylabel``) for a grid of plots of the same axes."""
    sup = [getattr(fig, name, None) for name in ("_supxlabel", "_supylabel")]
    supx, supy = (t.get_text() if t is not None else "" for t in sup)
    for ax in plot_axes(fig):
        for label in (ax.get_xlabel() or supx, ax.get_ylabel() or supy):
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


def fake_prediction(poses: int = 5, target=(2.6, 0.3, 0.9)):
    """A Prediction of a 3 x 3 m floor ahead of the camera: a blob of affordance before
    the target, ``poses`` poses along it facing the target."""
    import numpy as np

    from momakitchen.models.inference import Prediction

    g = np.stack(np.meshgrid(np.arange(0.8, 3.6, 0.04), np.arange(-1.4, 1.4, 0.04)), -1)
    xy = g.reshape(-1, 2)
    target = np.asarray(target, float)
    centre = target[:2] - [0.6, 0.0]
    affordance = np.exp(-np.sum((xy - centre) ** 2, 1) / 0.03).astype(np.float32)
    points = centre + np.c_[np.zeros(poses), np.linspace(-0.3, 0.3, poses)]
    yaws = np.arctan2(target[1] - points[:, 1], target[0] - points[:, 0])
    return Prediction(
        floor_xyz=np.c_[xy, np.zeros(len(xy))].astype(np.float32),
        affordance=affordance,
        uncertainty=(0.1 * affordance * (1 - affordance)).astype(np.float32),
        poses=np.c_[points, yaws],
        pose_scores=np.linspace(0.9, 0.5, poses),
        pose_uncertainty=np.full(poses, 0.02),
        target_xyz=target,
        robot="panda",
        model="navaff",
    )


def level_camera(height: float = 1.2):
    """A camera ``height`` above the floor at the base's origin, looking forward 30 deg
    down (OpenCV axes), and its 320 x 240 intrinsics."""
    import numpy as np

    from momakitchen.perception.camera import Intrinsics

    level = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    a = np.radians(30)
    down = np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])
    tf = np.eye(4)
    tf[:3, :3] = down @ level
    tf[:3, 3] = [0.0, 0.0, height]
    return tf, Intrinsics(280.0, 280.0, 160.0, 120.0, 320, 240)
