"""demo: the whole pipeline on one kitchen writes a report and a result; bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest

from momakitchen.cli.main import main
from momakitchen.frames import base_to_world_xy
from momakitchen.sim.config import STAGE_NAMES


def test_demo_writes_report_and_result(tiny_run, tmp_path, capsys, monkeypatch):
    import momakitchen.perception.figures as figures

    figs = []
    png_bytes = figures.png_bytes

    def keep(fig):  # the report's figure, kept for the checks below
        figs.append(fig)
        return png_bytes(fig)

    monkeypatch.setattr(figures, "png_bytes", keep)
    out = tmp_path / "demo"
    assert (
        main(
            [
                "demo",
                "--out",
                str(out),
                "--checkpoint",
                str(tiny_run),
                "--robot",
                "xarm6",
                "--scene-id",
                "5",
            ]
        )
        == 0
    )
    result = json.loads((out / "result.json").read_text())
    assert result["robot"] == "xarm6" and result["scene_id"] == 5
    assert result["trial"]["stage"] in STAGE_NAMES
    assert result["trial"]["success"] == (result["trial"]["stage"] == "success")
    # the trial ran where the chosen pose (viewpoint base frame) lies in the world
    world_xy = base_to_world_xy(
        np.array([result["chosen_pose_base_frame"][:2]]), result["viewpoint_base_pose_world"]
    )[0]
    np.testing.assert_allclose(world_xy, result["chosen_position_world"], atol=2e-4)
    steps = result["seconds"]
    assert sum(v for k, v in steps.items() if k != "total") == pytest.approx(
        steps["total"], abs=0.05
    )
    assert result["grid"]["trials"] > 0 and 0 <= result["ground_truth_at_pose"] <= 1
    assert (out / "report.png").stat().st_size > 50_000
    stdout = capsys.readouterr().out
    assert "[6/6] write the report" in stdout and "report.png" in stdout
    # Each step line shows that step's own duration, the number result.json records.
    from momakitchen.generation.demo import STEP_KEYS, STEPS

    for i, (name, key) in enumerate(zip(STEPS, STEP_KEYS, strict=True)):
        assert f"[{i + 1}/6] {name} ... {steps[key]:.2f} s\n" in stdout, stdout
    assert f"{steps['total']:.2f} s in all" in stdout
    _check_report_figure(figs[-1], result)


def _check_report_figure(fig, result):
    """The target is outlined in both image panels; the predicted and true top-down maps
    share one colour scale and show the region around the target, not the whole floor; no
    badge sits on a plot."""
    from matplotlib.collections import PathCollection

    axes = fig.axes
    images = [ax for ax in axes if ax.get_title().startswith(("1.", "3."))]
    maps = [ax for ax in axes if ax.get_title().startswith(("4.", "5."))]
    assert len(images) == 2 and len(maps) == 2
    for ax in images:
        assert any(t.get_text() == "target" for t in ax.texts), ax.get_title()
        assert len(ax.collections) >= 1 + (ax.get_title().startswith("3."))  # the outline
    scatters = [next(c for c in ax.collections if isinstance(c, PathCollection)) for ax in maps]
    norms = {(c.norm.vmin, c.norm.vmax) for c in scatters}
    assert len(norms) == 1, norms
    for ax, sc in zip(maps, scatters, strict=True):
        floor = np.asarray(sc.get_offsets())  # (-y, x) of every floor point
        (x0, x1), (y0, y1) = sorted(ax.get_xlim()), sorted(ax.get_ylim())
        star = next(line for line in ax.lines if line.get_marker() == "*")
        (sx,), (sy,) = star.get_data()
        assert x0 <= sx <= x1 and y0 <= sy <= y1  # the target is in view
        # Not the whole view down to the camera: the floor and the target, with
        # report_region's margin (and the poses, which lie on the floor).
        seen = np.vstack([floor, [[sx, sy]]])
        lo, hi = seen.min(0) - 0.41, seen.max(0) + 0.41
        assert lo[0] <= x0 < x1 <= hi[0] and lo[1] <= y0 < y1 <= hi[1]
        assert not [t for t in ax.texts if t.get_bbox_patch() is not None]  # no badge
    assert ("success" if result["trial"]["success"] else "failure") in maps[1].get_title()
    # The marks are explained: the target star has a legend entry.
    legend = maps[0].get_legend()
    assert legend is not None and "target" in [t.get_text() for t in legend.get_texts()]


def test_demo_bad_input(tmp_path, capsys):
    assert main(["demo", "--out", str(tmp_path / "a"), "--robot", "r2d2"]) == 2
    assert (
        main(["demo", "--out", str(tmp_path / "b"), "--checkpoint", str(tmp_path / "missing")]) == 2
    )
    assert main(["demo", "--out", str(tmp_path / "c"), "--config", "99"]) == 2
    err = capsys.readouterr().err
    assert "unknown robot 'r2d2'" in err and "does not exist" in err
    assert "--config must be in [0, 9], got 99" in err
    assert not any((tmp_path / d).exists() for d in "abc")  # nothing created on bad input


def test_report_region_is_the_floor_around_what_matters():
    """Of a 4 x 4 m floor, the report shows the part where the maps are above 10 % of the
    scale, the target and the poses, with a margin."""
    from momakitchen.generation.demo import report_region

    g = np.stack(np.meshgrid(np.arange(0.5, 4.5, 0.05), np.arange(-2, 2, 0.05)), -1)
    floor = np.column_stack([g.reshape(-1, 2), np.zeros(g.size // 2)])
    hot = np.exp(-np.sum((floor[:, :2] - [3.0, 0.5]) ** 2, 1) / 0.02)  # a blob at (3, 0.5)
    x0, x1, y0, y1 = report_region(floor, [hot, 0.3 * hot], 1.0, np.array([[3.4, 0.4]]))
    assert 2.0 < x0 < 2.8 and 3.7 < x1 < 3.9 and -0.3 < y0 < 0.3 and 0.7 < y1 < 1.3
    assert (x1 - x0) * (y1 - y0) < 0.15 * 16
    # A target beyond the seen floor (e.g. on a counter far ahead) stays in view.
    x0, x1, y0, y1 = report_region(floor, [hot], 1.0, np.array([[6.0, 0.4]]))
    assert x0 < 6.0 < x1 and y0 < 0.4 < y1


def test_the_legend_names_the_camera_only_where_the_map_shows_it():
    """The maps are cropped around the target: the robot's camera (at the origin) is in
    the legend only when the cropped region shows it."""
    from momakitchen.generation.demo import _legend_marks
    from momakitchen.perception.figures import pyplot

    plt = pyplot()
    for region, shown in (((1.0, 3.0, -1.0, 1.0), False), ((-0.2, 3.0, -1.0, 1.0), True)):
        fig, ax = plt.subplots()
        _legend_marks(ax, region)
        labels = [t.get_text() for t in ax.get_legend().get_texts()]
        plt.close(fig)
        assert ("robot (camera)" in labels) is shown and "target" in labels, labels


def test_demo_with_a_user_robot_on_a_drawn_mount(tiny_run, tmp_path):
    import pybullet_data

    from momakitchen.robots.user import unregister_user_robot

    urdf = f"{pybullet_data.getDataPath()}/franka_panda/panda.urdf"
    yaml_path = tmp_path / "pandademo.yaml"
    yaml_path.write_text(
        f"name: pandademo\nurdf: {urdf}\nmount_height: [0.6, 1.3]\nreach: 0.85\n"
        "end_effector_link: panda_grasptarget\nend_effector: parallel_gripper\n"
    )
    out = tmp_path / "demo"
    argv = ["demo", "--out", str(out), "--checkpoint", str(tiny_run), "--scene-id", "5"]
    try:
        assert main([*argv, "--robot", "pandademo", "--robot-yaml", str(yaml_path)]) == 0
    finally:
        unregister_user_robot("pandademo")
    result = json.loads((out / "result.json").read_text())
    assert result["robot"] == "pandademo" and 0.6 <= result["mount_height"] <= 1.3
    assert result["mount_height"] != 0.95  # drawn for the configuration, not the nominal
