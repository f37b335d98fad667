"""The benchmark's qualitative grid: one 0-1 colour scale and a colour bar, so that an
untrained model's flat map (maximum 0.06) does not look like a confident one."""

from __future__ import annotations

import numpy as np

from momakitchen.eval.report.figures import qualitative_grid


def test_every_map_shares_one_scale_and_a_colour_bar():
    rng = np.random.default_rng(0)
    xyz = np.c_[rng.uniform(0.5, 3, 200), rng.uniform(-1, 1, 200), np.zeros(200)]
    label = (rng.random(200) > 0.8).astype(np.float32)
    flat = np.full(200, 0.06, np.float32) * rng.random(200).astype(np.float32)
    fig = qualitative_grid([("ground truth", xyz, label, [("untrained", flat)])])
    maps = [ax for ax in fig.axes if ax.collections]
    coloured = [c for ax in maps for c in ax.collections if c.get_array() is not None]
    scales = {(c.norm.vmin, c.norm.vmax) for c in coloured}
    assert len(coloured) >= 2 and scales == {(0.0, 1.0)}
    bars = [ax for ax in fig.axes if ax.get_label() == "<colorbar>"]
    assert len(bars) == 1 and "affordance" in bars[0].get_ylabel()
    assert any("max 0.06" in ax.get_title() for ax in maps)
