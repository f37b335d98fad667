"""The demo's report as the README shows it (a page 860 pixels wide): every text 8 pt or
more there, the maps' axes in metres, the marks in a legend."""

from __future__ import annotations

import numpy as np

from figure_helpers import (
    assert_axes_labelled,
    assert_legible,
    captured_figures,
    fake_prediction,
    legend_labels,
    level_camera,
)


def test_the_report_is_legible_at_the_readme_width(monkeypatch):
    from momakitchen.generation.demo import report_figure

    pred = fake_prediction(poses=5)
    camera_to_base, intrinsics = level_camera()
    rgb = np.full((240, 320, 3), 120, np.uint8)
    depth = np.full((240, 320), 2.0, np.float32)
    mask = np.zeros((240, 320), bool)
    mask[40:60, 150:170] = True
    result = {
        "robot": "panda",
        "target": "bottle",
        "scene_id": 900001,
        "model": "navaff",
        "grid": {"trials": 100, "successes": 17},
        "chosen_pose_base_frame": [float(v) for v in pred.poses[0]],
        "predicted_affordance": 0.9,
        "uncertainty": 0.02,
        "ground_truth_at_pose": 1.0,
        "trial": {"success": True},
    }
    gt = (pred.affordance > 0.5).astype(np.float32)
    with captured_figures(monkeypatch) as figures:
        report_figure(rgb, depth, mask, intrinsics, camera_to_base, pred, gt, "success", result)
    (fig,) = figures
    assert_legible(fig)
    assert_axes_labelled(fig)
    assert {"target", "chosen pose"} <= set(legend_labels(fig))
    bars = [ax for ax in fig.axes if ax.get_label() == "<colorbar>"]
    assert any("(m)" in ax.get_ylabel() for ax in bars)  # the depth's unit
