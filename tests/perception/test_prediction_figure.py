"""prediction.png (predict, predict --bag, the README's picture): readable at the width a
page shows it, the Top-k poses numbered legibly and every mark in a legend."""

from __future__ import annotations

import numpy as np

from figure_helpers import (
    assert_axes_labelled,
    assert_legible,
    captured_figures,
    fake_prediction,
    legend_labels,
    level_camera,
    shown_points,
)
from momakitchen.perception.figures import prediction_figure


def test_the_picture_is_legible_and_explains_its_marks(monkeypatch):
    pred = fake_prediction(poses=5)
    camera_to_base, intrinsics = level_camera()
    rgb = np.full((240, 320, 3), 128, np.uint8)
    with captured_figures(monkeypatch) as figures:
        data = prediction_figure(pred, rgb, None, intrinsics, camera_to_base)
    assert data[:4] == b"\x89PNG"
    (fig,) = figures
    assert_legible(fig)
    assert_axes_labelled(fig)
    labels = legend_labels(fig)
    assert "target" in labels
    assert any(label.startswith("1: the best base pose") for label in labels), labels
    assert any(label.startswith("2–5") for label in labels), labels
    # The top-down map around the target numbers every pose, each number readable.
    (top,) = [ax for ax in fig.axes if ax.get_title().startswith("affordance around")]
    numbers = [t for t in top.texts if t.get_text() in {"1", "2", "3", "4", "5"}]
    assert sorted(t.get_text() for t in numbers) == ["1", "2", "3", "4", "5"]
    assert all(shown_points(fig, t) >= 9 for t in numbers)
    assert all(t.get_path_effects() for t in numbers)  # outlined: readable on any colour
    # Cropped around the target and the poses, not the whole floor down to the camera.
    y0, y1 = sorted(top.get_ylim())
    assert y0 > 0.5 and y1 >= pred.target_xyz[0]
    text = "\n".join(t.get_text() for ax in fig.axes for t in ax.texts)
    assert "best pose" in text and "from the camera" in text


def test_without_an_image_the_whole_floor_is_shown(monkeypatch):
    pred = fake_prediction(poses=1)
    with captured_figures(monkeypatch) as figures:
        prediction_figure(pred, None, None, None, None)
    (fig,) = figures
    assert_legible(fig)
    assert_axes_labelled(fig)
    assert not any(label.startswith("2") for label in legend_labels(fig))
