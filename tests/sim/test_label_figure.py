"""The label figure's orange marks all floor the mask sets to 0 (the base does not fit, or
beyond reach), as the README says, not only where it removed interpolated affordance."""

from __future__ import annotations

import numpy as np

from momakitchen.robots.spec import get_robot_spec
from momakitchen.scene.configuration import sample_scene
from momakitchen.scene.geometry import semicircle_grid
from momakitchen.sim.config import Stage
from momakitchen.sim.label_figure import floor_raster, save_label_figure
from momakitchen.sim.labels import Labels, standable

ORANGE = (1.0, 0.55, 0.1)


def test_orange_marks_every_masked_floor_point(tmp_path, monkeypatch):
    from matplotlib.figure import Figure

    scene = sample_scene(12)
    cfg = scene.configurations[1]
    layout = scene.layout
    reach = get_robot_spec(cfg.robot).reach
    grid = semicircle_grid(cfg.target.anchor[:2], reach, 0.1)
    stages = np.full(len(grid), int(Stage.BASE_COLLISION))
    stages[len(grid) // 2] = int(Stage.SUCCESS)  # one success: a small positive region
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
    figures = []
    original = Figure.savefig
    monkeypatch.setattr(
        Figure, "savefig", lambda self, *a, **k: (figures.append(self), original(self, *a, **k))
    )
    save_label_figure(layout, cfg, labels, tmp_path / "labels.png")
    ax = figures[0].axes[1]
    overlay = ax.images[1].get_array()
    ax_, ay_ = labels.anchor[:2]
    xlim = (ax_ - reach - 0.45, ax_ + reach + 0.45)
    ylim = (max(-0.1, ay_ - 0.6), ay_ + reach + 0.45)
    pts, free = floor_raster(layout, cfg, xlim, ylim)
    fits = standable(layout, cfg, pts.reshape(-1, 2)).reshape(free.shape)
    orange = np.all(np.isclose(overlay[..., :3], ORANGE), axis=-1) & (overlay[..., 3] > 0)
    assert (free & ~fits).sum() > 100
    assert np.array_equal(orange, free & ~fits)
