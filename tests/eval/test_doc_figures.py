"""The benchmark's qualitative grid and the robustness figure as the documents show them:
text of 8 pt or more at a page's width, axes in metres, the target marked in every map,
one robot per row before any robot comes again, and each robustness panel's outcome and
PCC."""

from __future__ import annotations

import numpy as np

from figure_helpers import (
    assert_axes_labelled,
    assert_legible,
    captured_figures,
    fake_prediction,
    legend_labels,
)


def _stars(ax):
    return [line for line in ax.lines if line.get_marker() == "*"]


def test_the_qualitative_grid_marks_the_target_in_every_map(real_dataset, tiny_run, monkeypatch):
    from momakitchen.data import EpisodeDataset
    from momakitchen.eval.report.figures import qualitative_figure

    data = EpisodeDataset(real_dataset, "test")
    feasible = {}
    for i, (_, sid, c, _e, robot) in enumerate(data.index):
        if float(data[i]["floor_label"].max()) > 0.5:
            feasible[(sid, c)] = robot
    with captured_figures(monkeypatch) as figures:
        qualitative_figure(real_dataset, [tiny_run], examples=len(feasible))
    (fig,) = figures
    assert_legible(fig)
    assert_axes_labelled(fig)
    maps = [ax for ax in fig.axes if ax.get_label() != "<colorbar>" and ax.axison]
    assert len(maps) == 2 * len(feasible) and all(len(_stars(ax)) == 1 for ax in maps)
    assert "target" in legend_labels(fig)
    # One robot per row while robots are left: the rows' robots in the split's order.
    rows = [ax.get_title().rsplit(", ", 1)[1] for ax in maps if "ground truth" in ax.get_title()]
    distinct = list(dict.fromkeys(feasible.values()))
    assert rows[: len(distinct)] == distinct


def test_qualitative_rows_come_one_robot_at_a_time(monkeypatch, tmp_path):
    """Of configurations by panda, panda, ur5e, panda, xarm6, four rows show panda, ur5e,
    xarm6 and then panda again."""
    import torch

    from momakitchen.eval.report import figures as report_figures

    robots = ["panda", "panda", "ur5e", "panda", "xarm6"]

    class Data:
        def __init__(self, root, split):
            self.index = [("f", 0, c, 0, r) for c, r in enumerate(robots)]

        def __getitem__(self, i):
            xyz = torch.zeros((10, 3))
            return {
                "floor_label": torch.ones(10),
                "floor_xyz": xyz,
                "global_xyz": xyz,
                "global_align": torch.ones(10),
                "robot_name": robots[i],
                "scene_id": 0,
                "config_index": i,
                "episode_index": 0,
            }

    import momakitchen.data as data_module

    monkeypatch.setattr(data_module, "EpisodeDataset", Data)
    rows = []
    monkeypatch.setattr(report_figures, "qualitative_grid", lambda r: rows.extend(r) or None)
    monkeypatch.setattr("momakitchen.perception.figures.png_bytes", lambda fig, dpi=0: b"")
    report_figures.qualitative_figure(tmp_path, [], examples=4)
    assert [r[0].rsplit(", ", 1)[1] for r in rows] == ["panda", "ur5e", "xarm6", "panda"]


def test_each_robustness_panel_says_its_outcome_and_pcc(monkeypatch):
    from momakitchen.eval.robustness.tables import robustness_figure

    pred = fake_prediction(poses=1)
    names = ["clean", "kinect", "pitch+2", "mono", "combined"]
    maps = {n: pred for n in names}
    maps["mono"] = {"status": "beyond_range"}
    views = {n: {"status": "ok", "outcomes": [1], "pcc": 0.812} for n in names}
    views["kinect"] = {"status": "ok", "outcomes": [0], "pcc": 0.5}
    views["mono"] = {"status": "beyond_range"}
    with captured_figures(monkeypatch) as figures:
        robustness_figure(maps, "one view under each corruption", views)
    (fig,) = figures
    assert_legible(fig)
    assert_axes_labelled(fig)
    titles = {ax.get_title().split("\n")[0]: ax.get_title() for ax in fig.axes if ax.get_title()}
    assert titles["clean"].endswith("Top-1 success, PCC 0.81")
    assert titles["kinect"].endswith("Top-1 failure, PCC 0.50")
    assert titles["mono"].endswith("no map")
    labels = legend_labels(fig)
    assert "target" in labels and any(label.startswith("1: the best") for label in labels)
    panels = [ax for ax in fig.axes if ax.get_title().split("\n")[0] in names]
    assert all(len(_stars(ax)) == 1 for ax in panels if ax.collections)
    # Without the records, the panels are named only.
    with captured_figures(monkeypatch) as figures:
        robustness_figure({"clean": pred}, "one view")
    assert [ax.get_title() for ax in figures[0].axes if ax.get_title()] == ["clean"]
    assert np.isfinite(pred.affordance).all()
